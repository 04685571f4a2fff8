#!/usr/bin/env bash
# The editor test: the real Godot editor, headless, on a copy of the demo project
# with the built addon and an editor-only test plugin (test_plugin/). The editor
# must load the ARDY plugin with no error from addons/ardy, and the test plugin
# drives the "Motion Timeline" dock (item moves, a mouse drag, adds, removes,
# their undo and redo). Prints "editor: N passed, N failed"; exits non-zero on
# any failure.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)
HERE=$ROOT/tests/godot/editor
GODOT=${GODOT:-$ROOT/.deps/bin/godot}
ADDON=$ROOT/demo_project/addons/ardy
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

fail() {
  echo "$1" >&2
  echo "editor: 0 passed, 1 failed"
  exit 1
}

[ -x "$GODOT" ] || fail "tests/godot/editor: no Godot at $GODOT (run scripts/deps.sh)"
[ -f "$ADDON/bin/libardy.linux.template_debug.x86_64.so" ] || {
  echo "tests/godot/editor: the extension is not built (run scripts/test.sh)" >&2; exit 2; }

# The demo project (without its engine cache) with the built addon and the test
# plugin, enabled after the ARDY plugin.
PROJECT=$WORK/project
mkdir -p "$PROJECT"
(cd "$ROOT/demo_project" && tar --exclude=./.godot -cf - .) | (cd "$PROJECT" && tar -xf -)
cp -r "$ADDON/bin" "$PROJECT/addons/ardy/"
cp -r "$HERE/test_plugin" "$PROJECT/addons/ardy_editor_test"
cp "$ROOT/tests/godot/project/probe.gd" "$PROJECT/probe.gd"
sed -i 's|^enabled=PackedStringArray("res://addons/ardy/plugin.cfg")$|enabled=PackedStringArray("res://addons/ardy/plugin.cfg", "res://addons/ardy_editor_test/plugin.cfg")|' \
  "$PROJECT/project.godot"
grep -q 'res://addons/ardy_editor_test/plugin.cfg' "$PROJECT/project.godot" \
  || fail "tests/godot/editor: could not enable the test plugin in project.godot"

godot() { timeout "$1" "$GODOT" --headless "${@:2}"; }

# The engine loads an extension only once an import has listed it in
# .godot/extension_list.cfg; a first import can miss it, so probe and retry.
loaded=0
for attempt in 1 2 3; do
  godot 300 --path "$PROJECT" --import >"$WORK/import.log" 2>&1
  if godot 120 --path "$PROJECT" -s res://probe.gd >"$WORK/probe.log" 2>&1; then
    loaded=1; break
  fi
  echo "tests/godot/editor: extension not loaded after import $attempt, importing again" >&2
done
[ $loaded -eq 1 ] || { cat "$WORK/import.log" "$WORK/probe.log" >&2; fail "tests/godot/editor: extension not loaded"; }

# The test plugin quits the editor when its checks are done; --quit-after and
# the timeout end a run whose test never started.
status=0
godot 300 --editor --path "$PROJECT" --quit-after 20000 >"$WORK/editor.log" 2>&1 || status=$?
grep -E '^(PASS|FAIL) ' "$WORK/editor.log"
read -r passed failed < <(sed -nE 's/^editor: ([0-9]+) passed, ([0-9]+) failed$/\1 \2/p' "$WORK/editor.log" | tail -1)
if [ -z "${passed:-}" ]; then
  echo "tests/godot/editor: the test plugin printed no result (editor exit $status); the log:" >&2
  cat "$WORK/editor.log" >&2
  passed=0; failed=1
elif [ $status -ne 0 ] && [ "$failed" -eq 0 ]; then
  echo "tests/godot/editor: the editor exited with $status" >&2
  failed=1
fi
# The load and the checks must leave no error of the addon in the editor's log.
if python3 "$HERE/check_editor_log.py" "$WORK/editor.log"; then
  passed=$((passed + 1))
else
  failed=$((failed + 1))
fi
echo "editor: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
