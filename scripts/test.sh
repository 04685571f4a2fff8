#!/usr/bin/env bash
# Sets up what is missing, builds everything and runs every test suite:
# C++ (Catch2 via ctest, plus AddressSanitizer and ThreadSanitizer builds),
# a short libFuzzer run of every fuzz harness, the C# bindings (Mono), the
# Windows build (MinGW-w64, run under Wine), the packaging scripts, Python
# (pytest), GDScript lint, and the engine tests (real Godot, headless).
# Ends with one "N passed, N failed, N skipped" line over all suites, counting
# C++ tests by Catch2 test case, fuzz harnesses, C#, Windows, packaging and
# engine tests by check, Python tests by pytest item; exits non-zero on any
# failure.
#
# Tests that need the Bandai Namco data skip without it (ARDY_BANDAI_DIR, by
# default ../shared/data/bandai); ARDY_REQUIRE_DATA=1 (set by .ci/run) makes
# that a failure. The build is always required here (this script makes it).
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
export HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1
export ARDY_REQUIRE_BUILD=1
# The Python suite tests this checkout's export_tools, whatever .venv was installed from.
export PYTHONPATH="$ROOT/export_tools${PYTHONPATH:+:$PYTHONPATH}"

bash scripts/deps.sh all || { echo "test.sh: setting up dependencies failed" >&2; exit 1; }
bash scripts/build.sh template_debug || { echo "test.sh: the build failed" >&2; exit 1; }
setup_seconds=$SECONDS

LOGS=$ROOT/build/test-logs
mkdir -p "$LOGS"
total_passed=0
total_failed=0
total_skipped=0
summary=()

# Each summary line ends with the suite's wall time since the one before it
# (a suite's own builds included), so the slow ones are easy to find.
suite_started=$SECONDS
record() {  # suite passed failed [skipped]
  local skipped=${4:-0}
  total_passed=$((total_passed + $2))
  total_failed=$((total_failed + $3))
  total_skipped=$((total_skipped + skipped))
  summary+=("$(printf '%-18s %5d passed, %d failed, %d skipped %6d s' "$1" "$2" "$3" "$skipped" $((SECONDS - suite_started)))")
  suite_started=$SECONDS
}

# ctest runs one executable per suite; each Catch2 suite writes an XML of its
# test cases, which tests/cpp/count_cases.py counts (and a crash as a failure).
run_ctest() {  # suite build_dir
  local log=$LOGS/$1.log
  rm -rf "$2/catch2-results"
  mkdir -p "$2/catch2-results"
  ctest --test-dir "$2" --output-on-failure 2>&1 | tee "$log"
  local passed failed
  python3 tests/cpp/count_cases.py "$2" "$log" >"$log.count" 2>&1
  grep '^FAIL' "$log.count" >&2
  read -r passed failed < <(tail -1 "$log.count")
  record "$1" "${passed:-0}" "${failed:-1}"
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

# A suite that prints one line per check and ends with "N passed, N failed".
run_checks() {  # suite command...
  local suite=$1 log=$LOGS/$1.log
  shift
  "$@" 2>&1 | tee "$log"
  local status=${PIPESTATUS[0]} passed failed
  read -r passed failed < <(sed -nE 's/^([0-9]+) passed, ([0-9]+) failed$/\1 \2/p' "$log" | tail -1)
  passed=${passed:-0}
  failed=${failed:-1}
  if [ "$status" -ne 0 ] && [ "$failed" -eq 0 ]; then
    failed=1  # failed outside the checks
  fi
  record "$suite" "$passed" "$failed"
}

# libFuzzer harnesses of tests/fuzz, 5 s each (bench/fuzz.sh runs them longer):
# one check per harness; a missing clang 14 / libFuzzer or a failed build is a
# failure (deps.sh all installs them), never a skip.
echo "== Fuzzing smoke run (libFuzzer + AddressSanitizer, 5 s per harness)"
run_checks fuzz bash bench/fuzz.sh --seconds 5 --fresh

echo "== C# bindings (Mono)"
run_checks csharp bash bindings/csharp/run_tests.sh

echo "== Windows build (MinGW-w64, checked under Wine)"
run_checks windows bash tests/windows/run.sh

echo "== Packaging (native archives, Godot addon zip)"
run_checks packaging bash tests/packaging/run.sh

echo "== Python tests"
.venv/bin/pytest -q -rfEs -p no:cacheprovider tests/python 2>&1 | tee "$LOGS/python.log"
py_status=${PIPESTATUS[0]}
# pytest's last line: "N failed, N passed, N skipped, N errors in 12.34s" (any subset).
py_line=$(grep -E '^(=+ )?[0-9]+ (passed|failed|skipped|errors?|deselected|xfailed|xpassed|warnings?)\b.* in [0-9.]+s' "$LOGS/python.log" | tail -1)
py_count() { echo "$py_line" | grep -oE "[0-9]+ ($1)\b" | awk '{ n += $1 } END { print n + 0 }'; }
py_passed=$(py_count 'passed|xpassed')
py_failed=$(py_count 'failed|errors?')
py_skipped=$(py_count 'skipped|xfailed')
if [ -z "$py_line" ] || { [ "$py_status" -ne 0 ] && [ "$py_failed" -eq 0 ]; }; then
  py_failed=$((py_failed + 1))  # pytest stopped without a result line, or failed outside the tests
fi
record "python" "$py_passed" "$py_failed" "$py_skipped"

echo "== Lint (ruff, gdlint)"
lint_failed=0
.venv/bin/ruff check export_tools tests/python tests/cpp src/tools gdextension/godot/tools tests/godot bench || lint_failed=$((lint_failed + 1))
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
printf '%-48s %6d s\n' "set-up (dependencies, build)" "$setup_seconds"
printf '%s\n' "${summary[@]}"
echo "$total_passed passed, $total_failed failed, $total_skipped skipped"
[ "$total_failed" -eq 0 ]
