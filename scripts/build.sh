#!/usr/bin/env bash
# Configures and builds everything with CMake (the one real build): the
# runtime, the Godot extension (into demo_project/addons/ardy/bin/) and the
# C++ tests. Usage: scripts/build.sh [template_debug|template_release] [cmake -D options...]
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
TARGET=${1:-template_debug}
shift || true
case $TARGET in
  template_debug) BUILD_TYPE=RelWithDebInfo ;;
  template_release) BUILD_TYPE=Release ;;
  *) echo "build.sh: unknown target '$TARGET' (template_debug or template_release)" >&2; exit 2 ;;
esac
BUILD=$ROOT/build/$TARGET
GENERATOR=()
if command -v ninja >/dev/null 2>&1 && [ ! -f "$BUILD/Makefile" ]; then
  GENERATOR=(-G Ninja)
fi
ORT_OPTION=()
[ -n "${ORT_ROOT:-}" ] && ORT_OPTION=(-DORT_ROOT="$ORT_ROOT")
mkdir -p "$ROOT/build"
cmake -S "$ROOT" -B "$BUILD" "${GENERATOR[@]}" -DCMAKE_BUILD_TYPE="$BUILD_TYPE" \
  -DARDY_BUILD_GDEXTENSION=ON "${ORT_OPTION[@]}" "$@" >"$BUILD.configure.log" 2>&1 \
  || { cat "$BUILD.configure.log" >&2; exit 1; }
cmake --build "$BUILD" --parallel "$(nproc)"
