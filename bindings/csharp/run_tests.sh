#!/usr/bin/env bash
# Builds the C# bindings (bindings/csharp/Ardy -> build/csharp/Ardy.dll) and their
# test program (bindings/csharp/Tests -> build/csharp/Tests.exe) with Mono's mcs,
# and runs the tests with mono against build/template_debug/src/libardy_c.so and
# the shipped model. Installs mono-mcs and mono-runtime with apt-get when they
# are missing. Prints one line per check and ends with the runner's
# "N passed, N failed" line; exits non-zero on any failure.
#
#   bash bindings/csharp/run_tests.sh        (after bash scripts/build.sh template_debug)
#
# ARDY_C_LIB_DIR: another directory holding libardy_c.so; ARDY_MODEL: another model folder.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$ROOT"
OUT=$ROOT/build/csharp
LIB_DIR=${ARDY_C_LIB_DIR:-$ROOT/build/template_debug/src}
MODEL=${ARDY_MODEL:-$ROOT/demo_project/addons/ardy/models/default}

fail() { echo "csharp: $*" >&2; echo "0 passed, 1 failed"; exit 1; }

if ! command -v mcs >/dev/null 2>&1 || ! command -v mono >/dev/null 2>&1; then
  echo "csharp: installing mono-mcs and mono-runtime"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO=sudo
  if ! { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
           mono-mcs mono-runtime >/dev/null; }; then
    fail "installing mono-mcs and mono-runtime failed"
  fi
fi
[ -f "$LIB_DIR/libardy_c.so" ] || fail "no $LIB_DIR/libardy_c.so (run: bash scripts/build.sh template_debug)"
[ -f "$MODEL/model.json" ] || fail "no model at $MODEL"

# libardy_c.so finds ONNX Runtime through its RUNPATH (.deps/ort/lib); the copy
# beside the Godot plugin serves when that is gone.
ORT_DIRS=""
for dir in "$ROOT/.deps/ort/lib" "$ROOT/demo_project/addons/ardy/bin"; do
  [ -f "$dir/libonnxruntime.so.1" ] && ORT_DIRS="$ORT_DIRS:$dir"
done
export LD_LIBRARY_PATH="$LIB_DIR$ORT_DIRS${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"

mkdir -p "$OUT"
echo "csharp: $(mcs --version), $(mono --version | head -1)"
# C# 7.2 is the newest mcs knows; -unsafe for the pointers inside (the public API is safe).
mcs -langversion:7.2 -unsafe -optimize+ -nologo -warnaserror+ -target:library -out:"$OUT/Ardy.dll" bindings/csharp/Ardy/*.cs \
  || fail "compiling bindings/csharp/Ardy failed"
mcs -langversion:7.2 -optimize+ -nologo -warnaserror+ -r:"$OUT/Ardy.dll" -out:"$OUT/Tests.exe" bindings/csharp/Tests/Tests.cs \
  || fail "compiling bindings/csharp/Tests failed"
# The header's struct layouts as the C compiler sees them, for the layout checks.
CC=${CC:-cc}
"$CC" -std=c11 -Wall -Werror -I src bindings/csharp/Tests/layout.c -o "$OUT/layout" || fail "compiling layout.c failed"
"$OUT/layout" >"$OUT/layout.txt" || fail "layout failed"
# The library's ardy_* exports, to check that every one is declared.
nm -D --defined-only "$LIB_DIR/libardy_c.so" | awk '$3 ~ /^ardy_/ { print $3 }' >"$OUT/symbols.txt" \
  || fail "listing the exports of libardy_c.so failed"

cd "$OUT"
timeout 900 mono --debug Tests.exe "$MODEL" "$OUT/layout.txt" "$OUT/symbols.txt" 2>&1 | tee "$OUT/tests.log"
status=${PIPESTATUS[0]}
last=$(tail -1 "$OUT/tests.log")
if ! [[ "$last" =~ ^[0-9]+\ passed,\ [0-9]+\ failed$ ]]; then
  echo "csharp: the test program stopped without its result line (exit $status)" >&2
  passed=$(grep -c '^PASS ' "$OUT/tests.log")
  echo "$passed passed, $(( $(grep -c '^FAIL ' "$OUT/tests.log") + 1 )) failed"
  exit 1
fi
[ "$status" -eq 0 ]
