#!/usr/bin/env bash
# The Godot addon as one zip laid out as the Asset Library expects: one
# top-level folder (stripped on install) holding addons/ardy/:
#   ardy-godot-<version>/
#     addons/ardy/ardy.gdextension, plugin.cfg, *.gd, *.uid
#     addons/ardy/bin/   libardy.linux.<T>.x86_64.so + libonnxruntime.so.1,
#                        libardy.windows.<T>.x86_64.dll + onnxruntime.dll,
#                        for each T of template_debug / template_release that is built
#     addons/ardy/models/default/   the model, MODEL_CARD.md, LICENSE.md (unless --no-model)
#     addons/ardy/docs/motion_generator.md, addons/ardy/LICENSE-*.{md,txt}
#     README.md, LICENSE-model.md, LICENSE-onnxruntime.txt, ThirdPartyNotices-onnxruntime.txt
#
#   scripts/package_addon.sh [--build] [--out DIR] [--no-model]
#     --build      build the release libraries that are missing first
#                  (scripts/build.sh template_release, scripts/build_windows.sh
#                  template_release); without it, what exists is packed and what
#                  is missing is named on stderr
#     --out DIR    where the zip goes (default: build/dist)
#     --no-model   leave models/default out (a small, fast zip)
# Where the libraries come from: the Linux extension from demo_project/addons/ardy/bin/
# (scripts/build.sh installs it there), the Windows one from build/windows-<T>/bin/
# (or demo_project/addons/ardy/bin/). Fails when no Linux library at all is built.
# Prints the zip's path on stdout and "package_addon.sh: PATH (SIZE)" on stderr.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OUT=$ROOT/build/dist
MODEL=1
BUILD=0
while [ $# -gt 0 ]; do
  case $1 in
    --build) BUILD=1; shift ;;
    --out) OUT=$2; shift 2 ;;
    --no-model) MODEL=0; shift ;;
    -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
    *) echo "package_addon.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done

ADDON=$ROOT/demo_project/addons/ardy
CACHE=${ARDY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/ardy-godot}
version=$(sed -nE 's/^#define ARDY_VERSION_(MAJOR|MINOR|PATCH) ([0-9]+).*/\2/p' "$ROOT/src/ardy_c.h" | paste -sd.)
linux_lib() { echo "$ADDON/bin/libardy.linux.$1.x86_64.so"; }
windows_lib() {
  local f=libardy.windows.$1.x86_64.dll
  if [ -f "$ROOT/build/windows-$1/bin/$f" ]; then echo "$ROOT/build/windows-$1/bin/$f"; else echo "$ADDON/bin/$f"; fi
}

if [ "$BUILD" = 1 ]; then
  [ -f "$(linux_lib template_release)" ] || nice bash "$ROOT/scripts/build.sh" template_release >&2
  [ -f "$(windows_lib template_release)" ] || nice bash "$ROOT/scripts/build_windows.sh" template_release >&2
fi

name=ardy-godot-$version
stage_root=$(mktemp -d)
trap 'rm -rf "$stage_root"' EXIT
dest=$stage_root/$name/addons/ardy
mkdir -p "$dest/bin" "$dest/docs"

# The addon's own files: what Godot needs to load it, never editor caches or imports.
for f in "$ADDON"/ardy.gdextension "$ADDON"/plugin.cfg "$ADDON"/*.gd "$ADDON"/*.uid; do
  if [ -f "$f" ]; then cp "$f" "$dest/"; fi
done

missing=()
linux=0 windows=0
for t in template_debug template_release; do
  if [ -f "$(linux_lib "$t")" ]; then cp "$(linux_lib "$t")" "$dest/bin/"; linux=1
  else missing+=("$(linux_lib "$t") (scripts/build.sh $t)"); fi
  if [ -f "$(windows_lib "$t")" ]; then cp "$(windows_lib "$t")" "$dest/bin/"; windows=1
  else missing+=("libardy.windows.$t.x86_64.dll (scripts/build_windows.sh $t)"); fi
done
# Debug info out of the copies (template_debug is RelWithDebInfo): a quarter of the size.
for f in "$dest"/bin/libardy.linux.*.so; do if [ -f "$f" ]; then strip --strip-debug "$f"; fi; done
if command -v x86_64-w64-mingw32-strip >/dev/null; then
  for f in "$dest"/bin/libardy.windows.*.dll; do if [ -f "$f" ]; then x86_64-w64-mingw32-strip --strip-debug "$f"; fi; done
fi
[ "$linux" = 1 ] || { echo "package_addon.sh: no Linux extension is built (run: bash scripts/build.sh template_debug, or pass --build)" >&2; exit 1; }
if [ -e "$ADDON/bin/libonnxruntime.so.1" ]; then
  cp -L "$ADDON/bin/libonnxruntime.so.1" "$dest/bin/"
elif [ -e "$ROOT/.deps/ort/lib/libonnxruntime.so.1" ]; then
  cp -L "$ROOT/.deps/ort/lib/libonnxruntime.so.1" "$dest/bin/"
else
  missing+=("libonnxruntime.so.1 (scripts/deps.sh)")
fi
if [ "$windows" = 1 ]; then
  ort_dll=""
  for d in "$ROOT/build/windows-template_release/bin" "$ROOT/build/windows-template_debug/bin" "$ADDON/bin" "$ROOT/.deps/ort-windows/bin"; do
    [ -f "$d/onnxruntime.dll" ] && { ort_dll=$d/onnxruntime.dll; break; }
  done
  if [ -n "$ort_dll" ]; then cp "$ort_dll" "$dest/bin/"; else missing+=("onnxruntime.dll (scripts/build_windows.sh)"); fi
fi

if [ "$MODEL" = 1 ]; then
  mkdir -p "$dest/models"
  cp -r "$ADDON/models/default" "$dest/models/default"
  rm -f "$dest"/models/default/*.import
fi
cp "$ROOT/docs/motion_generator.md" "$dest/docs/"
cp "$ADDON/models/default/LICENSE.md" "$dest/LICENSE-model.md"
cp "$ADDON/models/default/LICENSE.md" "$stage_root/$name/LICENSE-model.md"
wheel=$(ls "$CACHE"/wheels/onnxruntime-*manylinux*.whl "$CACHE"/wheels/onnxruntime-*.whl 2>/dev/null | head -1 || true)
if [ -n "$wheel" ]; then
  python3 - "$wheel" "$dest" "$stage_root/$name" <<'EOF'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    for src, dst in (("onnxruntime/LICENSE", "LICENSE-onnxruntime.txt"),
                     ("onnxruntime/ThirdPartyNotices.txt", "ThirdPartyNotices-onnxruntime.txt")):
        try:
            data = z.read(src)
        except KeyError:
            continue
        for folder in sys.argv[2:]:
            open(folder + "/" + dst, "wb").write(data)
EOF
else
  missing+=("ONNX Runtime's LICENSE (no wheel in $CACHE/wheels; scripts/deps.sh)")
fi
cat > "$stage_root/$name/README.md" <<EOF
# ARDY for Godot $version

Real-time generative character motion for Godot 4.5 or newer: the \`MotionGenerator\`
node (docs: \`addons/ardy/docs/motion_generator.md\`). Copy \`addons/ardy/\` into your
project (the Asset Library does this) and enable the plugin "ARDY".

Native libraries in \`addons/ardy/bin/\`: $(cd "$dest/bin" && ls | tr '\n' ' ')

The plugin's code is the ARDY for Godot project's. The default model
(\`addons/ardy/models/default/\`) is **CC BY-NC 4.0: non-commercial use only, with
attribution** (\`LICENSE-model.md\`). ONNX Runtime is MIT (\`LICENSE-onnxruntime.txt\`).
On Windows, ONNX Runtime needs the Microsoft Visual C++ 2015-2022 runtime.
EOF

for m in "${missing[@]}"; do echo "package_addon.sh: missing, not packed: $m" >&2; done
mkdir -p "$OUT"
archive=$(cd "$OUT" && pwd)/$name.zip
rm -f "$archive"
(cd "$stage_root" && python3 -m zipfile -c "$archive" "$name")
echo "$archive"
echo "package_addon.sh: $archive ($(du -h "$archive" | cut -f1))" >&2
