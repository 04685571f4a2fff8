#!/usr/bin/env bash
# The ablations of issue 5 at our scale, each on the same CPU budget (configs in
# export_tools/configs/ablations/): two-stage vs one-stage denoiser, and the tokenizer's
# decoder with the local root (paper) vs the global root. Trains, exports, evaluates each
# through the C++ CLI, then writes docs/evaluation/ablations.md (the 4 vs 10 DDIM steps rows
# come from the main evaluation, docs/evaluation/results.json). Runs that already finished
# are kept (delete runs/ablations/<name> to redo one).
#   scripts/run_ablations.sh        (about 45 minutes on 2 CPU cores)
set -euo pipefail
cd "$(dirname "$0")/.."
ardy=.venv/bin/ardy-export
configs=export_tools/configs/ablations
runs=runs/ablations

for root in local global; do
  [ -f "$runs/tokenizer_$root/final.pt" ] ||
    "$ardy" train tokenizer --config "$configs/tokenizer_$root.yaml"
done
for name in two_stage one_stage global_root; do
  [ -f "$runs/denoiser_$name/final.pt" ] ||
    "$ardy" train denoiser --config "$configs/denoiser_$name.yaml"
  [ -f "$runs/package_$name/model.json" ] ||
    "$ardy" export --checkpoint "$runs/denoiser_$name/final.pt" --out "$runs/package_$name"
  [ -f "$runs/eval_$name/results.json" ] ||
    "$ardy" eval run --config "$configs/evaluation.yaml" --model "$runs/package_$name" \
      --out "$runs/eval_$name" --sections text,constraints
done
"$ardy" eval ablations --runs "$runs" --main docs/evaluation/results.json \
  --out docs/evaluation/ablations.md
