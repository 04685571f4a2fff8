#!/usr/bin/env bash
# Renders the README's editor screenshots (docs/screenshots/editor_dock.png,
# editor_gizmos.png) from the real Godot editor on a virtual display: a copy of
# the demo project with the built addon, a scene made for the shots
# (tests/godot/editor/screenshots/build_scene.gd: the mannequin with a
# MotionGenerator and a timeline of prompts, waypoints, a path, a keyframe and
# a joint target) and a screenshot plugin (tests/godot/editor/screenshots/plugin)
# that opens it, selects the generator, generates the clip, shows it at 2 s in
# the "Motion Timeline" dock and the viewport, saves the pictures and quits.
# Needs the extension built (scripts/build.sh) and Xvfb.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
HERE=$ROOT/tests/godot/editor/screenshots
GODOT=${GODOT:-$ROOT/.deps/bin/godot}
ADDON=$ROOT/demo_project/addons/ardy
OUT=${1:-$ROOT/docs/screenshots}
WIDTH=1600
HEIGHT=900
WORK=$(mktemp -d)
XVFB_PID=""
cleanup() {
  [ -z "$XVFB_PID" ] || kill "$XVFB_PID" 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

[ -x "$GODOT" ] || { echo "editor_screenshots: no Godot at $GODOT (run scripts/deps.sh)" >&2; exit 2; }
[ -f "$ADDON/bin/libardy.linux.template_debug.x86_64.so" ] || {
  echo "editor_screenshots: the extension is not built (run scripts/build.sh)" >&2; exit 2; }
command -v Xvfb >/dev/null 2>&1 || { echo "editor_screenshots: needs Xvfb" >&2; exit 2; }

# The demo project (without its engine cache) with the screenshot plugin,
# enabled after the ARDY plugin.
PROJECT=$WORK/project
mkdir -p "$PROJECT" "$OUT"
(cd "$ROOT/demo_project" && tar --exclude=./.godot -cf - .) | (cd "$PROJECT" && tar -xf -)
cp -r "$HERE/plugin" "$PROJECT/addons/ardy_screenshots"
cp "$HERE/build_scene.gd" "$PROJECT/build_scene.gd"
sed -i 's|^enabled=PackedStringArray("res://addons/ardy/plugin.cfg")$|enabled=PackedStringArray("res://addons/ardy/plugin.cfg", "res://addons/ardy_screenshots/plugin.cfg")|' \
  "$PROJECT/project.godot"
grep -q 'res://addons/ardy_screenshots/plugin.cfg' "$PROJECT/project.godot" || {
  echo "editor_screenshots: could not enable the screenshot plugin" >&2; exit 1; }

# A clean editor (default layout and settings), not the user's.
export XDG_CONFIG_HOME=$WORK/config XDG_DATA_HOME=$WORK/data XDG_CACHE_HOME=$WORK/cache

# The engine loads an extension only once an import has listed it in
# .godot/extension_list.cfg; a first import can miss it, so build the scene
# (which needs the extension's classes) and retry after another import.
built=0
for attempt in 1 2 3; do
  timeout 300 "$GODOT" --headless --path "$PROJECT" --import >"$WORK/import.log" 2>&1 || true
  if timeout 120 "$GODOT" --headless --path "$PROJECT" -s res://build_scene.gd \
    >"$WORK/build.log" 2>&1; then
    built=1
    break
  fi
done
[ $built -eq 1 ] || { cat "$WORK/import.log" "$WORK/build.log" >&2
  echo "editor_screenshots: could not build the scene" >&2; exit 1; }
rm "$PROJECT/build_scene.gd"
timeout 300 "$GODOT" --headless --path "$PROJECT" --import >>"$WORK/import.log" 2>&1 || true

# A virtual display the size of the editor window.
number=90
while [ -e "/tmp/.X11-unix/X$number" ] || [ -e "/tmp/.X$number-lock" ]; do
  number=$((number + 1))
done
Xvfb ":$number" -screen 0 "${WIDTH}x${HEIGHT}x24" -nolisten tcp >/dev/null 2>&1 &
XVFB_PID=$!
export DISPLAY=":$number"
waited=0
until [ -e "/tmp/.X11-unix/X$number" ] || [ $waited -ge 50 ]; do
  sleep 0.1
  waited=$((waited + 1))
done

status=0
ARDY_EDITOR_SCREENSHOTS=$OUT timeout 400 "$GODOT" --rendering-driver opengl3 \
  --resolution "${WIDTH}x${HEIGHT}" --position 0,0 --editor --path "$PROJECT" \
  >"$WORK/editor.log" 2>&1 || status=$?
grep -E '^editor screenshots: ' "$WORK/editor.log" || true
if [ $status -ne 0 ] || ! grep -q '^editor screenshots: done' "$WORK/editor.log"; then
  echo "editor_screenshots: the editor failed (exit $status); the log:" >&2
  cat "$WORK/editor.log" >&2
  exit 1
fi
[ -z "${ARDY_EDITOR_LOG:-}" ] || cp "$WORK/editor.log" "$ARDY_EDITOR_LOG"
ls -1 "$OUT"/editor_dock.png "$OUT"/editor_gizmos.png
