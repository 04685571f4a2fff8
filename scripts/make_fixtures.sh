#!/usr/bin/env bash
# Regenerates every committed test fixture from the code that defines it:
#   tests/data/foundation/    ardy-export make-fixtures (tiny graphs, golden JSON)
#   tests/data/text/          ardy_export.cpp_fixtures (tokenizer cases, fake encoder)
#   tests/data/tiny_package/  ardy-export export-test-package (tiny package, goldens)
# Run it after changing the exporter, the models or the fixtures' definitions, and commit the
# result. The suite compares computed numbers within float32 tolerance
# (tests/python/fixture_compare.py), so a regeneration on another CPU need not be committed.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
export HF_HUB_OFFLINE=1 TRANSFORMERS_OFFLINE=1 PYTHONPATH="$ROOT/export_tools${PYTHONPATH:+:$PYTHONPATH}"
PYTHON=${PYTHON:-$ROOT/.venv/bin/python}
"$PYTHON" -m ardy_export.cli make-fixtures --out tests/data/foundation
"$PYTHON" -m ardy_export.cpp_fixtures
"$PYTHON" -m ardy_export.cli export-test-package --out tests/data/tiny_package
