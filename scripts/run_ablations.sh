#!/usr/bin/env bash
# The ablations of issue 5 at our scale, each on the same CPU budget (configs in
# export_tools/configs/ablations/). Trains, exports and evaluates each through the C++ CLI,
# then writes docs/evaluation/ablations.md (the 4 vs 10 DDIM steps rows of the shipped model
# are in the main report's text section). Runs that already finished are kept (delete
# runs/ablations/<name> to redo one).
#   scripts/run_ablations.sh            two-stage vs one-stage denoiser, on the shipped
#                                       model's tokenizer (about 40 minutes on 2 CPU cores)
#   scripts/run_ablations.sh --root     also the tokenizer's decoder with the global root vs
#                                       the local root (two more tokenizers; a GPU job)
set -euo pipefail
cd "$(dirname "$0")/.."
ardy=.venv/bin/ardy-export
configs=export_tools/configs/ablations
runs=runs/ablations

names=(two_stage one_stage)
if [ "${1:-}" = "--root" ]; then
  for root in local global; do
    [ -f "$runs/tokenizer_$root/final.pt" ] ||
      "$ardy" train tokenizer --config "$configs/tokenizer_$root.yaml"
  done
  names+=(local_root global_root)
fi
for name in "${names[@]}"; do
  [ -f "$runs/denoiser_$name/final.pt" ] ||
    "$ardy" train denoiser --config "$configs/denoiser_$name.yaml"
  [ -f "$runs/package_$name/model.json" ] ||
    "$ardy" export --checkpoint "$runs/denoiser_$name/final.pt" --out "$runs/package_$name"
  [ -f "$runs/eval_$name/results.json" ] ||
    "$ardy" eval run --config "$configs/evaluation.yaml" --model "$runs/package_$name" \
      --out "$runs/eval_$name" --sections text,constraints
done
"$ardy" eval ablations --runs "$runs" --out docs/evaluation/ablations.md
