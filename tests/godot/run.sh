#!/usr/bin/env bash
# Runs the engine tests: the real Godot, headless, loading the built extension.
# Prints "godot: N passed, N failed" over: the test project's runner (one per
# test_* method), the check that the engine printed no error line the tests did
# not declare (check_log.py), the harness's own test (planted failures,
# check_harness.py), the editor-help check, the exported-pack check, the demo
# driven by synthetic input and the editor test (tests/godot/editor/); exits
# non-zero on any failure.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
GODOT=${GODOT:-$ROOT/.deps/bin/godot}
PROJECT=$ROOT/tests/godot/project
ADDON=$ROOT/demo_project/addons/ardy
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

[ -f "$ADDON/bin/libardy.linux.template_debug.x86_64.so" ] || {
  echo "tests/godot: the extension is not built (run scripts/test.sh)" >&2; exit 2; }

# The project gets the built addon with the shipped default model, and the test
# graphs (both ignored by git).
rm -rf "$PROJECT/addons" "$PROJECT/fixtures"
mkdir -p "$PROJECT/addons" "$PROJECT/fixtures/model"
cp -r "$ADDON" "$PROJECT/addons/"
cp "$ROOT/tests/data/foundation/mlp.onnx" "$PROJECT/fixtures/mlp.onnx"
# The README, whose "Using the node" snippet test_readme.gd runs.
cp "$ROOT/README.md" "$PROJECT/fixtures/README.md"
# The tiny test package (model.json, graphs, vocabulary) as a model folder.
cp "$ROOT"/tests/data/tiny_package/{model.json,*.onnx,vocab.txt} "$PROJECT/fixtures/model/"

godot() { timeout 300 "$GODOT" --headless "$@"; }
# The CLI the timeline tests compare the node with.
export ARDY_CLI=${ARDY_CLI:-$ROOT/build/template_debug/src/ardy-generate}

# The engine loads an extension only once an import has listed it in
# .godot/extension_list.cfg; a first import can miss it, so probe and retry.
loaded=0
for attempt in 1 2 3; do
  godot --path "$PROJECT" --import >"$WORK/import.log" 2>&1
  if godot --path "$PROJECT" -s res://probe.gd >"$WORK/probe.log" 2>&1; then
    loaded=1; break
  fi
  echo "tests/godot: extension not loaded after import $attempt, importing again" >&2
done
if [ $loaded -ne 1 ]; then
  cat "$WORK/import.log" "$WORK/probe.log" >&2
  echo "0 passed, 1 failed"
  exit 1
fi

status=0
godot --path "$PROJECT" -s res://runner.gd 2>&1 | tee "$WORK/runner.log" || status=1
# Any ERROR / SCRIPT ERROR line beyond the errors the tests declared fails the run
# (errors at start-up or exit belong to no test and are seen only here).
python3 "$ROOT/tests/godot/check_log.py" "$WORK/runner.log" "engine output of the tests" \
  >"$WORK/runner-errors.log" 2>&1 || status=1
cat "$WORK/runner-errors.log"

# The harness's own test: a throwaway copy of the project whose only tests are the
# planted ones of tests/godot/harness/ (script errors, undeclared errors, a leaked
# model package); the runner must fail exactly those, for those reasons.
HARNESS=$WORK/harness
cp -r "$PROJECT" "$HARNESS"
rm -f "$HARNESS"/tests/test_*.gd "$HARNESS"/tests/test_*.gd.uid
cp "$ROOT/tests/godot/harness/test_planted.gd" "$HARNESS/tests/"
harness_status=0
godot --path "$HARNESS" -s res://runner.gd >"$WORK/planted.log" 2>&1 || harness_status=$?
python3 "$ROOT/tests/godot/check_harness.py" "$WORK/planted.log" "$harness_status" 2>&1 \
  | tee "$WORK/harness.log" || { status=1; cat "$WORK/planted.log" >&2; }

# The editor help must match what the engine registered.
mkdir -p "$WORK/docs"
if godot --path "$PROJECT" --doctool "$WORK/docs" --gdextension-docs >"$WORK/doctool.log" 2>&1; then
  python3 "$ROOT/tests/godot/check_docs.py" "$WORK/docs/doc_classes" "$ROOT/doc_classes" 2>&1 | tee "$WORK/docs.log" || status=1
else
  cat "$WORK/doctool.log" >&2
  echo "0 passed, 1 failed" >"$WORK/docs.log"
  status=1
fi

# An exported pack: the game must load the extension and read from the pack.
# An exported game carries the extension's libraries beside it, outside the
# pack; with --main-pack the engine resolves the res:// library paths of
# ardy.gdextension against the working folder, so they are laid out there.
mkdir -p "$WORK/export/addons/ardy/bin"
cp "$ADDON"/bin/*.so* "$WORK/export/addons/ardy/bin/"
if godot --path "$PROJECT" --export-pack "Linux" "$WORK/export/tests.pck" >"$WORK/export.log" 2>&1 \
    && [ -f "$WORK/export/tests.pck" ]; then
  (cd "$WORK/export" && godot --main-pack "$WORK/export/tests.pck") 2>&1 | tee "$WORK/pack.log" || status=1
  python3 "$ROOT/tests/godot/check_log.py" "$WORK/pack.log" "engine output of the exported pack" \
    >"$WORK/pack-errors.log" 2>&1 || status=1
  cat "$WORK/pack-errors.log"
else
  cat "$WORK/export.log" >&2
  echo "0 passed, 1 failed" >"$WORK/pack.log"
  status=1
fi

touch "$WORK/pack-errors.log"

# The demo driven as a player drives it (synthetic key and mouse events), in a
# copy of the demo project with the built addon.
DEMO=$WORK/demo
cp -r "$ROOT/demo_project" "$DEMO"
rm -rf "$DEMO/.godot"
cp -r "$ADDON/bin" "$DEMO/addons/ardy/"
cp "$ROOT"/tests/godot/demo/*.gd "$DEMO/"
# A first import can end in an engine crash at exit after writing its cache.
godot --path "$DEMO" --import >"$WORK/demo-import.log" 2>&1 || true
demo_logs=()
for test in test_demo_input test_crowd test_scene_switch; do
  godot --path "$DEMO" -s "res://$test.gd" 2>&1 | tee "$WORK/$test.log" || status=1
  python3 "$ROOT/tests/godot/check_log.py" "$WORK/$test.log" "engine output of $test" \
    >"$WORK/$test-errors.log" 2>&1 || status=1
  cat "$WORK/$test-errors.log"
  demo_logs+=("$WORK/$test.log" "$WORK/$test-errors.log")
done

# The editor: the ARDY plugin loads in the real editor and its timeline dock's
# edits undo and redo (tests/godot/editor/run.sh).
bash "$ROOT/tests/godot/editor/run.sh" 2>&1 | tee "$WORK/editor-run.log" || status=1
sed -nE 's/^editor: ([0-9]+ passed, [0-9]+ failed)$/\1/p' "$WORK/editor-run.log" >"$WORK/editor.log"
[ -s "$WORK/editor.log" ] || echo "0 passed, 1 failed" >"$WORK/editor.log"

read -r passed failed < <(grep -hE '^[0-9]+ passed, [0-9]+ failed$' "$WORK/runner.log" "$WORK/runner-errors.log" \
    "$WORK/harness.log" "$WORK/docs.log" "$WORK/pack.log" "$WORK/pack-errors.log" "$WORK/editor.log" "${demo_logs[@]}" | awk '{ p += $1; f += $3 } END { print p + 0, f + 0 }')
if [ "$passed" -eq 0 ] || [ $status -ne 0 ]; then
  failed=$((failed > 0 ? failed : 1))
fi
echo "godot: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
