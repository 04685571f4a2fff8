#!/usr/bin/env bash
# The demo. Sets up what is missing (the engine and ONNX Runtime, not the
# Python tools), builds the extension, imports the project and runs it:
#   scripts/demo.sh           the demo in a window; without a display it
#                             records the tour instead (below)
#   scripts/demo.sh --crowd   the crowd scene (50 characters)
#   scripts/demo.sh --tour    records the scripted tour (prompts, keyboard
#                             steering, waypoints, a keyframe, the crowd) to
#                             build/demo/tour.avi with Movie Maker, on a
#                             virtual display (Xvfb) when there is no screen
# Extra arguments go to Godot.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
mode=demo
case "${1:-}" in
  --crowd) mode=crowd; shift ;;
  --tour) mode=tour; shift ;;
esac
bash scripts/deps.sh runtime
bash scripts/build.sh template_debug >/dev/null
GODOT=$ROOT/.deps/bin/godot
PROJECT=$ROOT/demo_project

# The engine loads an extension only after an import listed it, and finds
# script classes (class_name) only after an import registered them: import
# every time (seconds), so an updated checkout runs as it is. A first import
# may end with an engine crash on exit (it still writes the cache), so its
# status is not used; the run below reports any real problem.
"$GODOT" --headless --path "$PROJECT" --import >/dev/null 2>&1 || true

if [ -z "${DISPLAY:-}" ] || [ -n "${ARDY_HEADLESS:-}" ]; then
  echo "demo.sh: no display: recording the tour on a virtual display" >&2
  mode=tour
  # shellcheck source=scripts/virtual_display.sh
  source scripts/virtual_display.sh
  start_virtual_display
fi

case $mode in
  demo) exec "$GODOT" --path "$PROJECT" "$@" ;;
  crowd) exec "$GODOT" --path "$PROJECT" "$@" res://crowd/crowd.tscn ;;
esac
OUT=$ROOT/build/demo
mkdir -p "$OUT"
rm -f "$OUT/tour.avi"
"$GODOT" --path "$PROJECT" --rendering-driver opengl3 --resolution 1280x720 \
  --write-movie "$OUT/tour.avi" --fixed-fps 30 "$@" res://tour/tour.tscn
echo "demo.sh: the tour is in $OUT/tour.avi ($(du -h "$OUT/tour.avi" | cut -f1))"
