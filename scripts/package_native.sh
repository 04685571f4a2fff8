#!/usr/bin/env bash
# The native bridge as archives for engines other than Godot (C, C++, C#
# P/Invoke, Unity, anything with a C FFI), one per platform:
#   build/dist/ardy-native-<version>-linux-x86_64.tar.gz
#   build/dist/ardy-native-<version>-windows-x86_64.zip
# Each holds one top-level folder of the same name with:
#   include/ardy_c.h          the C ABI
#   lib/                      Linux: libardy_c.so (exports only ardy_*) and
#                             libonnxruntime.so.1 beside it ($ORIGIN rpath);
#                             Windows: ardy_c.dll, onnxruntime.dll and the
#                             MinGW import library libardy_c.dll.a (when built)
#   bin/ardy-generate(.exe)   the offline CLI (JSON timeline -> BVH + JSON)
#   csharp/                   the C# bindings (bindings/csharp/Ardy/*.cs, README.md)
#   unity/                    the Unity package (bindings/csharp/Unity) with the
#                             bindings in Runtime/Ardy/ and that platform's
#                             libraries in Plugins/x86_64/
#   models/default/           the shipped model and its licence (unless --no-model)
#   examples/minimal.c, README.md (docs/native_bridge/)
#   LICENSE-model.md, LICENSE-onnxruntime.txt, ThirdPartyNotices-onnxruntime.txt
#
#   scripts/package_native.sh [--platform linux|windows|all] [--target T]
#                             [--build DIR] [--windows-build DIR] [--out DIR] [--no-model]
#     --platform P        linux, windows or all (default: all when the Windows
#                         build exists, else linux; only linux when --build is
#                         given, as before --platform existed)
#     --target T          template_release (default) or template_debug: picks the
#                         default build trees build/T and build/windows-T
#     --build DIR         a configured Linux CMake build tree (default: build/T,
#                         configured and built by scripts/build.sh when missing)
#     --windows-build DIR a Windows build tree made by scripts/build_windows.sh
#                         (default: build/windows-T; never built here)
#     --out DIR           where the archives go (default: build/dist)
#     --no-model          leave models/default out (small, fast archives)
# Prints each archive's path on stdout, one line each (the Linux one last), and
# "package_native.sh: PATH (SIZE)" on stderr.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD=""
WINBUILD=""
TARGET=template_release
PLATFORM=""
OUT=$ROOT/build/dist
MODEL=1
while [ $# -gt 0 ]; do
  case $1 in
    --build) BUILD=$2; shift 2 ;;
    --windows-build) WINBUILD=$2; shift 2 ;;
    --target) TARGET=$2; shift 2 ;;
    --platform) PLATFORM=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --no-model) MODEL=0; shift ;;
    -h|--help) sed -n '2,36p' "$0"; exit 0 ;;
    *) echo "package_native.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case $TARGET in template_debug|template_release) ;; *)
  echo "package_native.sh: unknown target '$TARGET' (template_debug or template_release)" >&2; exit 2 ;;
esac
[ -n "$WINBUILD" ] || WINBUILD=$ROOT/build/windows-$TARGET
if [ -z "$PLATFORM" ]; then
  if [ -n "$BUILD" ]; then PLATFORM=linux
  elif [ -f "$WINBUILD/bin/ardy_c.dll" ]; then PLATFORM=all; else PLATFORM=linux; fi
fi
case $PLATFORM in
  linux) platforms=(linux) ;;
  windows) platforms=(windows) ;;
  all) platforms=(windows linux) ;;
  *) echo "package_native.sh: unknown platform '$PLATFORM' (linux, windows or all)" >&2; exit 2 ;;
esac

header=$ROOT/src/ardy_c.h
version=$(sed -nE 's/^#define ARDY_VERSION_(MAJOR|MINOR|PATCH) ([0-9]+).*/\2/p' "$header" | paste -sd.)
CACHE=${ARDY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/ardy-godot}
stage_root=$(mktemp -d)
trap 'rm -rf "$stage_root"' EXIT
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

# ONNX Runtime's LICENSE and ThirdPartyNotices from its PyPI wheel (the one the
# build used), when the wheel is in the download cache. $1: manylinux or win_amd64.
ort_licences() {
  local wheel dest=$2
  wheel=$(ls "$CACHE"/wheels/onnxruntime-*-"$1"*.whl 2>/dev/null | head -1 || true)
  [ -n "$wheel" ] || wheel=$(ls "$CACHE"/wheels/onnxruntime-*.whl 2>/dev/null | head -1 || true)
  if [ -z "$wheel" ]; then
    echo "package_native.sh: no ONNX Runtime wheel in $CACHE/wheels: its LICENSE is left out" >&2
    return 0
  fi
  python3 - "$wheel" "$dest" <<'EOF'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    for src, dst in (("onnxruntime/LICENSE", "LICENSE-onnxruntime.txt"),
                     ("onnxruntime/ThirdPartyNotices.txt", "ThirdPartyNotices-onnxruntime.txt")):
        try:
            data = z.read(src)
        except KeyError:
            continue
        open(sys.argv[2] + "/" + dst, "wb").write(data)
EOF
}

# What both platforms share: header, C#, Unity package, model, example, docs, licences.
common() {
  local stage=$1 wheel_tag=$2
  mkdir -p "$stage/include" "$stage/examples" "$stage/csharp/Ardy"
  cp "$header" "$stage/include/"
  cp "$ROOT/docs/native_bridge/minimal.c" "$stage/examples/"
  cp "$ROOT/docs/native_bridge/README.md" "$stage/README.md"
  cp "$ROOT"/bindings/csharp/Ardy/*.cs "$stage/csharp/Ardy/"
  cp "$ROOT/bindings/csharp/README.md" "$stage/csharp/"
  # The Unity package: its own files (no Plugins/ or .meta files from a checkout
  # that was opened in Unity), the bindings as Runtime/Ardy/, the libraries added by the caller.
  mkdir -p "$stage/unity"
  (cd "$ROOT/bindings/csharp/Unity" && tar --exclude=./Plugins -cf - .) | tar -C "$stage/unity" -xf -
  mkdir -p "$stage/unity/Runtime/Ardy" "$stage/unity/Plugins/x86_64"
  cp "$ROOT"/bindings/csharp/Ardy/*.cs "$stage/unity/Runtime/Ardy/"
  cp "$ROOT/demo_project/addons/ardy/models/default/LICENSE.md" "$stage/LICENSE-model.md"
  ort_licences "$wheel_tag" "$stage"
  if [ "$MODEL" = 1 ]; then
    mkdir -p "$stage/models"
    cp -r "$ROOT/demo_project/addons/ardy/models/default" "$stage/models/default"
    rm -f "$stage"/models/default/*.import
  fi
}

report() { echo "$1"; echo "package_native.sh: $1 ($(du -h "$1" | cut -f1))" >&2; }

package_linux() {
  if [ -z "$BUILD" ]; then
    BUILD=$ROOT/build/$TARGET
    [ -f "$BUILD/CMakeCache.txt" ] || bash "$ROOT/scripts/build.sh" "$TARGET" >&2
  fi
  [ -f "$BUILD/CMakeCache.txt" ] || { echo "package_native.sh: $BUILD is not a CMake build tree" >&2; exit 1; }
  cmake --build "$BUILD" --target ardy_c ardy-generate >&2
  local name=ardy-native-$version-linux-$(uname -m)
  local stage=$stage_root/$name
  cmake --install "$BUILD" --component native_bridge --prefix "$stage" --strip >&2
  common "$stage" manylinux
  cp -P "$stage/lib/libardy_c.so" "$stage/lib/libonnxruntime.so.1" "$stage/unity/Plugins/x86_64/"
  local archive=$OUT/$name.tar.gz
  rm -f "$archive"
  tar -C "$stage_root" -czf "$archive" "$name"
  report "$archive"
}

package_windows() {
  local bin=$WINBUILD/bin f
  for f in ardy_c.dll ardy-generate.exe onnxruntime.dll; do
    [ -f "$bin/$f" ] || { echo "package_native.sh: $bin/$f is missing (run: bash scripts/build_windows.sh $TARGET)" >&2; exit 1; }
  done
  local name=ardy-native-$version-windows-x86_64
  local stage=$stage_root/$name
  mkdir -p "$stage/lib" "$stage/bin"
  cp "$bin/ardy_c.dll" "$bin/onnxruntime.dll" "$stage/lib/"
  cp "$bin/ardy-generate.exe" "$stage/bin/"
  # ardy-generate.exe imports ardy_c.dll and onnxruntime.dll: Windows looks beside the .exe.
  cp "$bin/ardy_c.dll" "$bin/onnxruntime.dll" "$stage/bin/"
  if [ -f "$WINBUILD/src/libardy_c.dll.a" ]; then cp "$WINBUILD/src/libardy_c.dll.a" "$stage/lib/"; fi
  if command -v x86_64-w64-mingw32-strip >/dev/null; then
    x86_64-w64-mingw32-strip --strip-unneeded "$stage/lib/ardy_c.dll" "$stage/bin/ardy_c.dll" "$stage/bin/ardy-generate.exe"
  fi
  common "$stage" win_amd64
  cp "$stage/lib/ardy_c.dll" "$stage/lib/onnxruntime.dll" "$stage/unity/Plugins/x86_64/"
  local archive=$OUT/$name.zip
  rm -f "$archive"
  (cd "$stage_root" && python3 -m zipfile -c "$archive" "$name")
  report "$archive"
}

for p in "${platforms[@]}"; do "package_$p"; done
