#!/usr/bin/env bash
# Trains the shipped default model (tokenizer, then denoiser) with the committed configs in
# export_tools/configs/default_model/. Used on a lent GPU machine, where the data arrives as
# a compact copy (ardy-export data pack-compact) and the text as a label bank
# (ardy-export text bank); locally it works the same from data/processed.
#
#   scripts/train_default_model.sh [TOKENIZER_SECONDS] [DENOISER_SECONDS]
#
# Each stage stops at its time budget (its last checkpoint is kept, see latest.pt) or at its
# configured step count; a budget of 0 skips the stage (its final.pt must exist). PYTHON
# defaults to .venv/bin/python, else python3; COMPACT names the compact data copy.
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
PYTHON=${PYTHON:-$([ -x .venv/bin/python ] && echo .venv/bin/python || echo python3)}
export PYTHONPATH=$ROOT/export_tools${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TOKENIZER_SECONDS=${1:-3600}
DENOISER_SECONDS=${2:-7200}
CONFIGS=export_tools/configs/default_model
ardy() { "$PYTHON" -m ardy_export.cli "$@"; }

COMPACT=${COMPACT:-data/compact}
if [ ! -f data/processed/clips.npz ] && [ -f "$COMPACT/compact.npz" ]; then
  ardy data unpack-compact "$COMPACT" --out data/processed || exit 1
fi
[ -f data/processed/normalization.npz ] || ardy data stats || exit 1
[ -f runs/text/bank.npz ] || ardy text bank --out runs/text/bank.npz || exit 1

# A stage cut by its time budget leaves latest.pt: that becomes final.pt.
finish() {  # run_dir
  [ -f "$1/final.pt" ] || cp "$1/latest.pt" "$1/final.pt"
}
if [ "$TOKENIZER_SECONDS" -gt 0 ]; then
  timeout "$TOKENIZER_SECONDS" "$PYTHON" -m ardy_export.cli train tokenizer \
    --config "$CONFIGS/tokenizer.yaml" --quiet
  finish runs/default/tokenizer || exit 1
fi
if [ "$DENOISER_SECONDS" -gt 0 ]; then
  timeout "$DENOISER_SECONDS" "$PYTHON" -m ardy_export.cli train denoiser \
    --config "$CONFIGS/denoiser.yaml" --quiet
  finish runs/default/denoiser || exit 1
fi
ls -la runs/default/tokenizer runs/default/denoiser
