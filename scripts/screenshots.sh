#!/usr/bin/env bash
# Renders the README's screenshots (docs/screenshots/*.png) from the current
# build: the demo's scripted tour (demo_project/tour/tour.gd) saves a picture
# of each feature as it plays. Uses a virtual display (Xvfb) when there is no
# screen. Run scripts/demo.sh (or build.sh) first so the build is current.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
bash scripts/deps.sh runtime
bash scripts/build.sh template_debug >/dev/null
GODOT=$ROOT/.deps/bin/godot
PROJECT=$ROOT/demo_project
"$GODOT" --headless --path "$PROJECT" --import >/dev/null 2>&1 || true
if [ -z "${DISPLAY:-}" ] || [ -n "${ARDY_HEADLESS:-}" ]; then
  # shellcheck source=scripts/virtual_display.sh
  source scripts/virtual_display.sh
  start_virtual_display
fi
"$GODOT" --path "$PROJECT" --rendering-driver opengl3 --resolution 1280x720 --fixed-fps 30 \
  res://tour/tour.tscn -- --screenshots "$ROOT/docs/screenshots"
ls -1 "$ROOT"/docs/screenshots/*.png
