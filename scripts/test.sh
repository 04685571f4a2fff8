#!/usr/bin/env bash
# Sets up what is missing, builds everything and runs every test suite:
# C++ (Catch2 via ctest, plus AddressSanitizer and ThreadSanitizer builds),
# Python (pytest), GDScript lint, and the engine tests (real Godot, headless).
# Ends with one "N passed, N failed" line over all suites; exits non-zero on
# any failure.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
export HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1

bash scripts/deps.sh all || { echo "test.sh: setting up dependencies failed" >&2; exit 1; }
bash scripts/build.sh template_debug || { echo "test.sh: the build failed" >&2; exit 1; }

LOGS=$ROOT/build/test-logs
mkdir -p "$LOGS"
total_passed=0
total_failed=0
summary=()

record() {  # suite passed failed
  total_passed=$((total_passed + $2))
  total_failed=$((total_failed + $3))
  summary+=("$(printf '%-18s %5d passed, %d failed' "$1" "$2" "$3")")
}

# ctest prints "100% tests passed, 0 tests failed out of N".
run_ctest() {  # suite build_dir
  local log=$LOGS/$1.log
  ctest --test-dir "$2" --output-on-failure 2>&1 | tee "$log"
  local total failed
  total=$(sed -nE 's/.*tests failed out of ([0-9]+).*/\1/p' "$log" | tail -1)
  failed=$(sed -nE 's/.* ([0-9]+) tests failed out of.*/\1/p' "$log" | tail -1)
  if [ -z "$total" ]; then record "$1" 0 1; return; fi
  record "$1" $((total - failed)) "$failed"
}

echo "== C++ tests"
run_ctest "cpp" "$ROOT/build/template_debug"

for sanitizer in address thread; do
  echo "== C++ tests under the $sanitizer sanitizer"
  dir=$ROOT/build/sanitize-$sanitizer
  if cmake -S "$ROOT" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DARDY_BUILD_GDEXTENSION=OFF \
        -DARDY_SANITIZE=$sanitizer >"$LOGS/configure-$sanitizer.log" 2>&1 \
      && cmake --build "$dir" --parallel "$(nproc)" >"$LOGS/build-$sanitizer.log" 2>&1; then
    run_ctest "cpp ($sanitizer)" "$dir"
  else
    cat "$LOGS/configure-$sanitizer.log" "$LOGS/build-$sanitizer.log" >&2
    record "cpp ($sanitizer)" 0 1
  fi
done

echo "== Python tests"
.venv/bin/pytest -q -p no:cacheprovider tests/python 2>&1 | tee "$LOGS/python.log"
py_passed=$(grep -oE '[0-9]+ passed' "$LOGS/python.log" | tail -1 | cut -d' ' -f1)
py_failed=$(grep -oE '[0-9]+ (failed|error)' "$LOGS/python.log" | awk '{ n += $1 } END { print n + 0 }')
if [ -z "$py_passed" ]; then py_passed=0; py_failed=$((py_failed > 0 ? py_failed : 1)); fi
record "python" "$py_passed" "$py_failed"

echo "== Lint (ruff, gdlint)"
lint_failed=0
.venv/bin/ruff check export_tools tests/python src/tools gdextension/godot/tools tests/godot bench || lint_failed=$((lint_failed + 1))
mapfile -t gd_files < <(git ls-files '*.gd')
if [ ${#gd_files[@]} -gt 0 ]; then
  .venv/bin/gdlint "${gd_files[@]}" || lint_failed=$((lint_failed + 1))
fi
record "lint" $((2 - lint_failed)) "$lint_failed"

echo "== Engine tests"
bash tests/godot/run.sh 2>&1 | tee "$LOGS/godot.log"
read -r gd_passed gd_failed < <(sed -nE 's/^godot: ([0-9]+) passed, ([0-9]+) failed$/\1 \2/p' "$LOGS/godot.log" | tail -1)
record "godot" "${gd_passed:-0}" "${gd_failed:-1}"

echo
echo "== Summary"
printf '%s\n' "${summary[@]}"
echo "$total_passed passed, $total_failed failed"
[ "$total_failed" -eq 0 ]
