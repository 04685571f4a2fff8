#!/usr/bin/env bash
# The native bridge as one archive for engines other than Godot (C, C++, C#
# P/Invoke, anything with a C FFI):
#   include/ardy_c.h          the C ABI
#   lib/libardy_c.so          the runtime (exports only ardy_*), and
#   lib/libonnxruntime.so.1   beside it (found through an $ORIGIN rpath)
#   bin/ardy-generate         the offline CLI (JSON timeline -> BVH + JSON)
#   models/default/           the shipped model and its licence (unless --no-model)
#   examples/minimal.c, README.md (docs/native_bridge/)
#
#   scripts/package_native.sh [--build DIR] [--out DIR] [--no-model]
#     --build DIR   a configured CMake build tree (default: build/template_release,
#                   configured and built by scripts/build.sh when missing)
#     --out DIR     where the .tar.gz goes (default: build/dist)
# Prints the archive's path.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD=""
OUT=$ROOT/build/dist
MODEL=1
while [ $# -gt 0 ]; do
  case $1 in
    --build) BUILD=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --no-model) MODEL=0; shift ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) echo "package_native.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done

if [ -z "$BUILD" ]; then
  BUILD=$ROOT/build/template_release
  [ -f "$BUILD/CMakeCache.txt" ] || bash "$ROOT/scripts/build.sh" template_release >&2
fi
[ -f "$BUILD/CMakeCache.txt" ] || { echo "package_native.sh: $BUILD is not a CMake build tree" >&2; exit 1; }
cmake --build "$BUILD" --target ardy_c ardy-generate >&2

header=$ROOT/src/ardy_c.h
version=$(sed -nE 's/^#define ARDY_VERSION_(MAJOR|MINOR|PATCH) ([0-9]+).*/\2/p' "$header" | paste -sd.)
name=ardy-native-$version-linux-$(uname -m)
stage_root=$(mktemp -d)
trap 'rm -rf "$stage_root"' EXIT
stage=$stage_root/$name
cmake --install "$BUILD" --component native_bridge --prefix "$stage" --strip >&2
mkdir -p "$stage/examples"
cp "$ROOT/docs/native_bridge/minimal.c" "$stage/examples/"
cp "$ROOT/docs/native_bridge/README.md" "$stage/README.md"
if [ "$MODEL" = 1 ]; then
  mkdir -p "$stage/models"
  cp -r "$ROOT/demo_project/addons/ardy/models/default" "$stage/models/default"
  rm -f "$stage"/models/default/*.import
fi
mkdir -p "$OUT"
archive=$(cd "$OUT" && pwd)/$name.tar.gz
tar -C "$stage_root" -czf "$archive" "$name"
echo "$archive"
