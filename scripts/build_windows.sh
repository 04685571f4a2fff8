#!/usr/bin/env bash
# Cross-builds the Windows x86_64 binaries with MinGW-w64 (cmake/mingw-w64-x86_64.cmake):
# ardy_c.dll (the C ABI), ardy-generate.exe and the Godot
# extension libardy.windows.<target>.x86_64.dll, all into
# build/windows-<target>/bin/ beside onnxruntime.dll (and
# onnxruntime_providers_shared.dll) from the PyPI win_amd64 wheel.
#
# Usage: scripts/build_windows.sh [template_debug|template_release] [cmake -D options...]
#
# Installs what is missing: the MinGW-w64 compilers, mingw-w64-tools (gendef)
# and Wine (for tests/windows/run.sh) from the machine's own Debian when run as
# root (else it names them); the ONNX Runtime wheel into the cache deps.sh
# uses, unpacked into .deps/ort-windows/ with an import library made by
# gendef + dlltool. The ORT headers, GLM, nlohmann/json and the Linux Godot
# (which dumps the extension interface at build time) come from scripts/deps.sh.
# ARDY_WINDOWS_GDEXTENSION=OFF skips the extension (and the Godot download).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
TARGET=${1:-template_debug}
shift || true
case $TARGET in
  template_debug) BUILD_TYPE=RelWithDebInfo ;;
  template_release) BUILD_TYPE=Release ;;
  *) echo "build_windows.sh: unknown target '$TARGET' (template_debug or template_release)" >&2; exit 2 ;;
esac
DEPS=$ROOT/.deps
CACHE=${ARDY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/ardy-godot}
BUILD=$ROOT/build/windows-$TARGET
ORT_VERSION=1.31.1
ORT_WIN=$DEPS/ort-windows
TRIPLE=x86_64-w64-mingw32
GDEXT=${ARDY_WINDOWS_GDEXTENSION:-ON}

log() { printf '[build_windows] %s\n' "$*" >&2; }

# 1. Host tools from the machine's Debian.
missing=()
command -v $TRIPLE-g++-posix >/dev/null || missing+=(g++-mingw-w64-x86-64-posix)
command -v $TRIPLE-gcc-posix >/dev/null || missing+=(gcc-mingw-w64-x86-64-posix)
command -v $TRIPLE-dlltool >/dev/null || missing+=(binutils-mingw-w64-x86-64)
command -v gendef >/dev/null || missing+=(mingw-w64-tools)
{ command -v wine64 >/dev/null || [ -x /usr/lib/wine/wine64 ]; } || missing+=(wine wine64)
command -v cmake >/dev/null || missing+=(cmake)
command -v ninja >/dev/null || missing+=(ninja-build)
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -eq 0 ]; then
    log "installing: ${missing[*]}"
    apt-get update -q >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "build_windows.sh: missing tools; run: sudo apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi

# 2. Headers (ORT's C/C++ API headers serve every platform), GLM, json, Godot.
if [ "$GDEXT" = ON ]; then
  bash "$ROOT/scripts/deps.sh" runtime
else
  for d in ort glm json; do
    [ -f "$DEPS/.stamp-$d" ] || [ -L "$DEPS/$d" ] || { bash "$ROOT/scripts/deps.sh" runtime; break; }
  done
fi

# 3. ONNX Runtime for Windows: onnxruntime.dll from the wheel, an import library for MinGW.
if [ ! -f "$DEPS/.stamp-ort-windows" ]; then
  log "ONNX Runtime $ORT_VERSION for Windows (PyPI win_amd64 wheel) into .deps/ort-windows"
  mkdir -p "$CACHE/wheels"
  ls "$CACHE"/wheels/onnxruntime-"$ORT_VERSION"-*win_amd64.whl >/dev/null 2>&1 ||
    python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.11 --platform win_amd64 \
      "onnxruntime==$ORT_VERSION" -d "$CACHE/wheels"
  wheel=$(ls "$CACHE"/wheels/onnxruntime-"$ORT_VERSION"-*win_amd64.whl | head -1)
  rm -rf "$ORT_WIN" "$DEPS/ort-windows-tmp"
  mkdir -p "$ORT_WIN/bin" "$ORT_WIN/lib" "$ORT_WIN/include" "$DEPS/ort-windows-tmp"
  python3 -m zipfile -e "$wheel" "$DEPS/ort-windows-tmp"
  cp "$DEPS/ort-windows-tmp/onnxruntime/capi/onnxruntime.dll" "$ORT_WIN/bin/"
  cp "$DEPS/ort-windows-tmp/onnxruntime/capi/onnxruntime_providers_shared.dll" "$ORT_WIN/bin/" 2>/dev/null || true
  rm -rf "$DEPS/ort-windows-tmp"
  cp -r "$(readlink -f "$DEPS/ort")/include/onnxruntime" "$ORT_WIN/include/"
  # The wheel has no import library: gendef lists the DLL's exports, dlltool makes libonnxruntime.dll.a.
  (cd "$ORT_WIN/lib" && gendef - "$ORT_WIN/bin/onnxruntime.dll" > onnxruntime.def 2>/dev/null &&
    $TRIPLE-dlltool -D onnxruntime.dll -d onnxruntime.def -l libonnxruntime.dll.a)
  grep -q OrtGetApiBase "$ORT_WIN/lib/onnxruntime.def" || { echo "build_windows.sh: gendef found no OrtGetApiBase" >&2; exit 1; }
  touch "$DEPS/.stamp-ort-windows"
fi

# 4. Configure and build.
mkdir -p "$BUILD"
GENERATOR=()
if command -v ninja >/dev/null 2>&1 && [ ! -f "$BUILD/Makefile" ]; then
  GENERATOR=(-G Ninja)
fi
log "configuring $BUILD ($BUILD_TYPE)"
cmake -S "$ROOT" -B "$BUILD" "${GENERATOR[@]}" \
  -DCMAKE_TOOLCHAIN_FILE="$ROOT/cmake/mingw-w64-x86_64.cmake" \
  -DCMAKE_BUILD_TYPE="$BUILD_TYPE" \
  -DARDY_BUILD_TESTS=OFF -DARDY_BUILD_GDEXTENSION="$GDEXT" \
  -DORT_ROOT="$ORT_WIN" \
  -DORT_INCLUDE_DIR="$ORT_WIN/include/onnxruntime" \
  -DORT_LIBRARY="$ORT_WIN/lib/libonnxruntime.dll.a" \
  -DORT_DLL="$ORT_WIN/bin/onnxruntime.dll" \
  -DCMAKE_RUNTIME_OUTPUT_DIRECTORY="$BUILD/bin" \
  -DARDY_ADDON_BIN="$BUILD/bin" \
  "$@" >"$BUILD.configure.log" 2>&1 || { cat "$BUILD.configure.log" >&2; exit 1; }
log "building"
# ardy-bench is left out: bench/ardy_bench.cpp reads getrusage (sys/resource.h).
targets=(ardy_c ardy-generate)
[ "$GDEXT" = ON ] && targets+=(ardy_gdextension)
nice cmake --build "$BUILD" --parallel "$(nproc)" --target "${targets[@]}"
cp -u "$ORT_WIN"/bin/*.dll "$BUILD/bin/"
log "done: $(cd "$BUILD/bin" && ls -- *.dll *.exe | tr '\n' ' ')"
