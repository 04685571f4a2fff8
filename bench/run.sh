#!/usr/bin/env bash
# Benchmark tables of the C++ runtime and the PyTorch reference on this
# machine, same model and thread count (design.md section 9). Not a test.
#
#   bench/run.sh                          # random-weight package of the default size
#   bench/run.sh --package DIR --checkpoint CKPT.pt   # a trained package and its checkpoint
#   options: --threads N (C++ intra-op threads; default: the runtime's, all cores but one;
#            PyTorch always gets every core, its fastest), --repeats N (default 30),
#            --crowd-seconds S (real-time play of each crowd; default 10), --crowds LIST
#            (planners per crowd; default 8,16,50; "" for none),
#            --future-tokens N (future goal tokens; default: the model's maximum, as the planner),
#            --spin (ONNX Runtime threads spin while idle), --shared-pool (one intra-op
#            pool for every graph; with --spin the fastest setting), --tiny-text (random package
#            with a tiny text encoder), --no-reference
#
# Without --package, bench/make_model.py writes a random-weight package of the
# sizes in export_tools/configs/{tokenizer,denoiser}.yaml (and its PyTorch
# checkpoint) into build/bench_model/ once. ardy-bench is built in Release
# into build/bench/. Results (JSON and the tables) go to build/bench_results/.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PACKAGE=""
CHECKPOINT=""
THREADS=""
TORCH_THREADS=$(nproc)
REPEATS=30
TINY_TEXT=""
REFERENCE=1
FUTURE=-1
SPIN=
SHARED=
CROWD_SECONDS=10
CROWDS=8,16,50
while [ $# -gt 0 ]; do
  case $1 in
    --package) PACKAGE=$2; shift 2 ;;
    --checkpoint) CHECKPOINT=$2; shift 2 ;;
    --threads) THREADS=$2; shift 2 ;;
    --repeats) REPEATS=$2; shift 2 ;;
    --tiny-text) TINY_TEXT=--tiny-text; shift ;;
    --future-tokens) FUTURE=$2; shift 2 ;;
    --spin) SPIN=--spin; shift ;;
    --shared-pool) SHARED=--shared-pool; shift ;;
    --no-reference) REFERENCE=0; shift ;;
    --crowd-seconds) CROWD_SECONDS=$2; shift 2 ;;
    --crowds) CROWDS=$2; shift 2 ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "bench/run.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done

PY=$ROOT/.venv/bin/python
BUILD=$ROOT/build/bench
OUT=$ROOT/build/bench_results
mkdir -p "$OUT"

GENERATOR=()
if command -v ninja >/dev/null 2>&1 && [ ! -f "$BUILD/Makefile" ]; then GENERATOR=(-G Ninja); fi
cmake -S "$ROOT" -B "$BUILD" "${GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Release -DARDY_BUILD_GDEXTENSION=OFF \
  -DARDY_BUILD_TESTS=OFF >"$OUT/configure.log" 2>&1 || { cat "$OUT/configure.log" >&2; exit 1; }
cmake --build "$BUILD" --target ardy-bench --parallel "$(nproc)" >"$OUT/build.log" 2>&1 \
  || { cat "$OUT/build.log" >&2; exit 1; }

LABEL=""
if [ -z "$PACKAGE" ]; then
  PACKAGE=$ROOT/build/bench_model
  # (Re)made when missing or of an older package format than the runtime reads.
  if [ ! -f "$PACKAGE/reference.pt" ] || ! grep -q '"format_version": 2,' "$PACKAGE/model.json" 2>/dev/null; then
    echo "bench: writing a random-weight package of the default size into $PACKAGE" >&2
    "$PY" "$ROOT/bench/make_model.py" --out "$PACKAGE" $TINY_TEXT >"$OUT/make_model.log" 2>&1 \
      || { cat "$OUT/make_model.log" >&2; exit 1; }
  fi
  CHECKPOINT=${CHECKPOINT:-$PACKAGE/reference.pt}
  LABEL="random-weight package of the default size ($(tr -d '\n ' <"$PACKAGE/bench_sizes.json"))"
fi
[ -f "$PACKAGE/model.json" ] || { echo "bench: $PACKAGE has no model.json" >&2; exit 1; }

"$PY" "$ROOT/bench/make_probe.py" --out "$OUT/matmul_probe.onnx"
echo "bench: C++ runtime on $PACKAGE (intra-op threads: ${THREADS:-the runtime default})" >&2
"$BUILD/src/ardy-bench" --package "$PACKAGE" ${THREADS:+--threads "$THREADS"} --repeats "$REPEATS" \
  --future-tokens "$FUTURE" $SPIN $SHARED --probe "$OUT/matmul_probe.onnx" --crowd-seconds "$CROWD_SECONDS" \
  --crowds "$CROWDS" --json "$OUT/cpp.json" ${LABEL:+--label "$LABEL"} >"$OUT/cpp.md"

if [ "$REFERENCE" = 1 ] && [ -n "$CHECKPOINT" ]; then
  echo "bench: PyTorch reference on $CHECKPOINT ($TORCH_THREADS threads)" >&2
  "$PY" "$ROOT/bench/reference.py" --checkpoint "$CHECKPOINT" --threads "$TORCH_THREADS" --repeats "$REPEATS" \
    --future-tokens "$FUTURE" --json "$OUT/torch.json" >/dev/null
  "$PY" "$ROOT/bench/report.py" "$OUT/cpp.json" "$OUT/torch.json" | tee "$OUT/report.md"
else
  [ "$REFERENCE" = 1 ] && echo "bench: no --checkpoint for the PyTorch reference; C++ only" >&2
  "$PY" "$ROOT/bench/report.py" "$OUT/cpp.json" | tee "$OUT/report.md"
fi
