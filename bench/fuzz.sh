#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz (clang 14 from scripts/deps.sh,
# AddressSanitizer) and runs each for N seconds (default 600), then prints a
# table: executions, coverage (libFuzzer's cov: edges and ft: features of its
# final stats line), crashes (crash-, leak-, timeout-, oom- files written) and
# slow units (inputs over 10 s: reported, not failures; a hang is a timeout).
#
#   bench/fuzz.sh [--seconds N] [--fresh] [harness...]
#   harnesses: package onnx_scan timeline wordpiece c_api
#
# The corpus grows in build/fuzz-corpus/<harness>/ (kept between runs; seeds
# from tests/fuzz/seeds and tests/data); --fresh starts from the seeds alone
# in build/fuzz-corpus-fresh/ (the smoke run of scripts/test.sh, whose time
# must not grow with the kept corpus). Findings go to
# build/fuzz-findings/<harness>/, logs to build/fuzz-logs/. Also prints one
# "PASS"/"FAIL" line per harness and "N passed, N failed" (the fuzz suite
# of scripts/test.sh runs it with --seconds 5 --fresh). Exits non-zero on any
# finding or build failure. ARDY_FUZZ_JOBS: build jobs (default: all cores).
# Reproduce a finding: build/fuzz/fuzz_<harness> build/fuzz-findings/<harness>/crash-...
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
ALL=(package onnx_scan timeline wordpiece c_api)
seconds=600
fresh=0
harnesses=()
while [ $# -gt 0 ]; do
  case $1 in
    --seconds)
      [ $# -ge 2 ] && [[ $2 =~ ^[0-9]+$ ]] && [ "$2" -gt 0 ] || { echo "fuzz.sh: --seconds needs a whole number of seconds > 0" >&2; exit 2; }
      seconds=$2; shift 2 ;;
    --fresh) fresh=1; shift ;;
    -h|--help) sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "fuzz.sh: unknown option $1 (expected --seconds N, --fresh and harness names)" >&2; exit 2 ;;
    *)
      [[ " ${ALL[*]} " == *" $1 "* ]] || { echo "fuzz.sh: unknown harness '$1' (expected: ${ALL[*]})" >&2; exit 2; }
      harnesses+=("$1"); shift ;;
  esac
done
[ ${#harnesses[@]} -gt 0 ] || harnesses=("${ALL[@]}")

BUILD=$ROOT/build/fuzz
CORPUS=$ROOT/build/fuzz-corpus
if [ "$fresh" -eq 1 ]; then
  CORPUS=$ROOT/build/fuzz-corpus-fresh
  rm -rf "$CORPUS"
fi
FINDINGS=$ROOT/build/fuzz-findings
LOGS=$ROOT/build/fuzz-logs
SEEDS=$ROOT/build/fuzz-seeds
mkdir -p "$LOGS"

# --- build: a missing toolchain or a failed build is a failure, never a skip.
build_failed() {
  echo "FAIL build: $1 (log: $2)"
  tail -20 "$2" >&2 || true
  echo "0 passed, 1 failed"
  exit 1
}
bash scripts/deps.sh fuzz >"$LOGS/deps.log" 2>&1 || build_failed "installing clang 14 and libFuzzer (scripts/deps.sh fuzz)" "$LOGS/deps.log"
cmake -S tests/fuzz -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER="$ROOT/.deps/bin/clang-14" -DCMAKE_CXX_COMPILER="$ROOT/.deps/bin/clang++-14" \
  >"$LOGS/configure.log" 2>&1 || build_failed "configuring tests/fuzz" "$LOGS/configure.log"
targets=()
for h in "${harnesses[@]}"; do targets+=("fuzz_$h"); done
cmake --build "$BUILD" --parallel "${ARDY_FUZZ_JOBS:-$(nproc)}" --target "${targets[@]}" \
  >"$LOGS/build.log" 2>&1 || build_failed "building the harnesses" "$LOGS/build.log"

# --- seeds: files as each harness reads them (package: a selector byte, 128 + the
# file's index, then the file).
make_seeds() {  # harness -> seed folder
  local h=$1 dir=$SEEDS/$1 tiny=$ROOT/tests/data/tiny_package
  rm -rf "$dir"; mkdir -p "$dir"
  case $h in
    package)
      # Indexes of every package file but the goldens, in name order (the harness's
      # selector). Seeds: model.json, vocab.txt and the smallest graph only; a
      # loaded package costs six ONNX Runtime sessions, so megabyte graphs as
      # seeds would make nearly every run slow (onnx_scan fuzzes graph bytes).
      local i=0 f
      while read -r f; do
        case $f in
          model.json|vocab.txt|history.onnx)
            { printf "\\$(printf '%03o' $((128 + i)))"; cat "$tiny/$f"; } >"$dir/$f" ;;
        esac
        i=$((i + 1))
      done < <(cd "$tiny" && LC_ALL=C find . -maxdepth 1 -type f ! -name 'goldens.*' -printf '%f\n' | LC_ALL=C sort) ;;
    onnx_scan)
      for f in "$tiny"/*.onnx; do cp "$f" "$dir/"; done
      printf 'denoiser.onnx' >"$dir/name"
      # graph { initializer { name "W", external_data { "location": "w.bin" }, data_location EXTERNAL } }
      printf '\x3a\x1a\x2a\x18\x42\x01W\x6a\x11\x0a\x08location\x12\x05w.bin\x70\x01' >"$dir/external" ;;
    timeline) cp "$ROOT"/tests/fuzz/seeds/timeline/* "$dir/" ;;
    wordpiece)
      for f in "$ROOT"/tests/fuzz/seeds/wordpiece/*; do
        { printf '\001'; cat "$f"; } >"$dir/lower-$(basename "$f")"
        { printf '\002'; cat "$f"; } >"$dir/cased-$(basename "$f")"
      done
      { printf '\201'; head -200 "$ROOT/tests/data/text/vocab.txt"; } >"$dir/vocab" ;;
    c_api) printf '\001\002\003\004\005\006\007\010\011\012\013\014\015\016\017\020\021' >"$dir/ops" ;;
  esac
}

# --- run
passed=0
failed=0
rows=()
for h in "${harnesses[@]}"; do
  make_seeds "$h"
  mkdir -p "$CORPUS/$h" "$FINDINGS/$h"
  # Findings: crash-, leak-, timeout-, oom- files. libFuzzer also keeps slow-unit-
  # files (an input over 10 s, e.g. on a loaded machine); those are counted apart.
  findings() { find "$FINDINGS/$h" -type f ! -name 'slow-unit-*' | wc -l; }
  slow_units() { find "$FINDINGS/$h" -type f -name 'slow-unit-*' | wc -l; }
  before=$(findings)
  slow_before=$(slow_units)
  log=$LOGS/$h.log
  status=0
  # -timeout: one input running 30 s is a hang; -rss_limit_mb: ONNX Runtime
  # sessions of the package harness need more than libFuzzer's 2 GB default.
  "$BUILD/fuzz_$h" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$FINDINGS/$h/" "$CORPUS/$h" "$SEEDS/$h" >"$log" 2>&1 || status=$?
  after=$(findings)
  crashes=$((after - before))
  slow=$(($(slow_units) - slow_before))
  # The last stats line: "#1234	DONE   cov: 567 ft: 890 corp: ..." (or the last pulse/NEW line).
  stats=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  runs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+)/\1/p' "$log" | tail -1)
  [ -n "$runs" ] || runs=$(echo "$stats" | sed -nE 's/^#([0-9]+).*/\1/p')
  cov=$(echo "$stats" | sed -nE 's/.* cov: ([0-9]+).*/\1/p')
  ft=$(echo "$stats" | sed -nE 's/.* ft: ([0-9]+).*/\1/p')
  if [ "$status" -ne 0 ] && [ "$crashes" -eq 0 ]; then crashes=1; fi  # died without an artifact
  rows+=("$(printf '%-10s %12s %8s %8s %8s %10s' "$h" "${runs:-?}" "${cov:-?}" "${ft:-?}" "$crashes" "$slow")")
  if [ "$status" -eq 0 ] && [ "$crashes" -eq 0 ] && [ -n "$cov" ]; then
    echo "PASS fuzz_$h: ${runs:-?} executions in ${seconds} s, cov ${cov}, ft ${ft:-?}, no crashes" \
      "(slowest input $(sed -nE 's/^stat::slowest_unit_time_sec: *([0-9]+)/\1/p' "$log" | tail -1) s)"
    passed=$((passed + 1))
  else
    echo "FAIL fuzz_$h: exit status $status, $crashes finding(s) in $FINDINGS/$h (log: $log)"
    grep -E 'ERROR: |SUMMARY: |invariant broken|==[0-9]+==' "$log" | head -5 || true
    failed=$((failed + 1))
  fi
done

echo
printf '%-10s %12s %8s %8s %8s %10s\n' harness executions cov ft crashes slow-units
printf '%s\n' "${rows[@]}"
echo "corpus: $CORPUS; findings: $FINDINGS; logs: $LOGS"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
