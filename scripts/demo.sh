#!/usr/bin/env bash
# Sets up what is missing (the engine and ONNX Runtime, not the Python tools),
# builds the extension and runs the demo project. Without a display it runs
# headless and reports what it checked. Extra arguments go to Godot.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
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
if [ -n "${DISPLAY:-}" ] && [ -z "${ARDY_HEADLESS:-}" ]; then
  exec "$GODOT" --path "$PROJECT" "$@"
fi
echo "demo.sh: no display, running headless (set DISPLAY to see the demo)" >&2
exec "$GODOT" --headless --path "$PROJECT" "$@"
