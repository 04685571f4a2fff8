#!/usr/bin/env bash
# Installs everything the build and the tests need into .deps/ and .venv/
# (both ignored), from the package registries only. Idempotent: each step
# leaves a stamp and is skipped when its stamp is present.
#
# Overrides: GODOT=/path/to/godot uses your own engine (4.4 or newer);
# ORT_ROOT=/path with include/onnxruntime/*.h and lib/libonnxruntime.so.1
# uses your own ONNX Runtime.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
DEPS=$ROOT/.deps
CACHE=${ARDY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/ardy-godot}
mkdir -p "$DEPS/bin" "$CACHE/debs"

ORT_VERSION=1.31.1
CATCH2_VERSION=3.7.1

log() { printf '[deps] %s\n' "$*" >&2; }
stamp_ok() { [ -f "$DEPS/.stamp-$1" ]; }
stamp_set() { touch "$DEPS/.stamp-$1"; }

# The Debian mirror this machine already uses (never written into the repo).
debian_mirror() {
  local uri=""
  if [ -f /etc/apt/sources.list.d/debian.sources ]; then
    uri=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
  fi
  if [ -z "$uri" ] && [ -f /etc/apt/sources.list ]; then
    uri=$(awk '$1 == "deb" { for (i = 2; i <= NF; i++) if ($i ~ /^[a-z]+:\/\//) { print $i; exit } }' /etc/apt/sources.list)
  fi
  [ -n "$uri" ] || { echo "deps: cannot find a Debian mirror in /etc/apt" >&2; exit 1; }
  echo "${uri%/}"
}

# A private apt configuration: nothing on the host changes.
APT_DIR=$DEPS/apt
private_apt() {
  apt-get -q -o Dir::Etc::sourcelist="$APT_DIR/sources.list" -o Dir::Etc::sourceparts=/dev/null \
    -o Dir::State::Lists="$APT_DIR/lists" -o Dir::Cache="$APT_DIR/cache" \
    -o Dir::State::status="$APT_DIR/status" -o APT::Install-Recommends=false \
    -o Debug::NoLocking=1 -o APT::Sandbox::User=root "$@"
}

apt_setup() {
  stamp_ok apt && return 0
  log "private apt configuration"
  local mirror; mirror=$(debian_mirror)
  mkdir -p "$APT_DIR/lists/partial" "$APT_DIR/cache/archives/partial"
  : > "$APT_DIR/status"
  cat > "$APT_DIR/sources.list" <<SRC
deb $mirror sid main
deb $mirror bookworm main
deb-src $mirror trixie main
SRC
  # Prefer bookworm where a package exists in both (GLM), sid for the rest.
  private_apt update >/dev/null 2>"$APT_DIR/update.log" || { cat "$APT_DIR/update.log" >&2; exit 1; }
  stamp_set apt
}

# Download a package closure (the .debs cached outside the checkout) and
# extract it into a root folder.
extract_debs() {  # root_dir apt-args...
  local root=$1; shift
  mkdir -p "$root"
  private_apt -o Dir::Cache::archives="$CACHE/debs" install --download-only -y "$@" >/dev/null
  private_apt -s install -y "$@" | awk '/^Inst / {print $2, $3}' | tr -d '()' |
    while read -r name ver; do
      local deb; deb=$(ls "$CACHE/debs/${name}_${ver//:/%3a}"_*.deb 2>/dev/null | head -1 || true)
      [ -n "$deb" ] || { echo "deps: missing download for $name $ver" >&2; exit 1; }
      dpkg-deb -x "$deb" "$root"
    done
}

install_godot() {
  if [ -n "${GODOT:-}" ]; then
    log "using GODOT=$GODOT"
    ln -sf "$GODOT" "$DEPS/bin/godot"
    rm -f "$DEPS/.stamp-godot"  # unsetting GODOT later reinstalls the wrapper
    return 0
  fi
  stamp_ok godot && return 0
  apt_setup
  log "Godot 4.6 from Debian sid into .deps/sid-root (about 160 MB, cached)"
  extract_debs "$DEPS/sid-root" -t sid godot libgl1-mesa-dri libglx-mesa0 libegl-mesa0 libgl1 libegl1
  local r=$DEPS/sid-root
  cat > "$DEPS/bin/godot" <<WRAP
#!/bin/sh
# Runs Debian sid's Godot with its own loader and libraries (see toolchain.md).
R="$r"
export LIBGL_DRIVERS_PATH="\$R/usr/lib/x86_64-linux-gnu/dri"
export __EGL_VENDOR_LIBRARY_DIRS="\$R/usr/share/glvnd/egl_vendor.d"
exec "\$R/usr/lib64/ld-linux-x86-64.so.2" --library-path "\$R/usr/lib/x86_64-linux-gnu:\$R/usr/lib/x86_64-linux-gnu/pulseaudio" "\$R/usr/bin/godot" "\$@"
WRAP
  chmod +x "$DEPS/bin/godot"
  "$DEPS/bin/godot" --headless --version >/dev/null
  stamp_set godot
}

install_ort() {
  if [ -n "${ORT_ROOT:-}" ]; then
    log "using ORT_ROOT=$ORT_ROOT"
    rm -rf "$DEPS/ort"; ln -sfn "$ORT_ROOT" "$DEPS/ort"
    rm -f "$DEPS/.stamp-ort"
    return 0
  fi
  stamp_ok ort && return 0
  apt_setup
  log "ONNX Runtime $ORT_VERSION (PyPI wheel) + C/C++ headers (Debian sid)"
  local ort=$DEPS/ort
  rm -rf "$ort" "$DEPS/ort-tmp"; mkdir -p "$ort/lib" "$ort/include" "$DEPS/ort-tmp"
  pip download -q --no-deps --only-binary=:all: --python-version 3.11 --platform manylinux_2_28_x86_64 \
    "onnxruntime==$ORT_VERSION" -d "$CACHE/wheels"
  # The Linux wheel only: the cache may hold the Windows one too (build_windows.sh).
  python3 -m zipfile -e "$CACHE"/wheels/onnxruntime-"$ORT_VERSION"-*manylinux_2_28_x86_64.whl "$DEPS/ort-tmp"
  cp "$DEPS/ort-tmp/onnxruntime/capi/libonnxruntime.so.$ORT_VERSION" "$ort/lib/"
  ln -sf "libonnxruntime.so.$ORT_VERSION" "$ort/lib/libonnxruntime.so.1"
  ln -sf libonnxruntime.so.1 "$ort/lib/libonnxruntime.so"
  rm -rf "$DEPS/ort-tmp"
  (cd "$CACHE/debs" && private_apt download -t sid libonnxruntime-dev >/dev/null)
  local hdr; hdr=$(ls -t "$CACHE"/debs/libonnxruntime-dev_*.deb | head -1)
  dpkg-deb -x "$hdr" "$DEPS/ort-tmp"
  cp -r "$DEPS/ort-tmp/usr/include/onnxruntime" "$ort/include/"
  rm -rf "$DEPS/ort-tmp"
  stamp_set ort
}

# A header-only library from Debian bookworm: its usr/include/SUBDIR into .deps/NAME/include.
install_headers() {  # name package version_glob subdir description
  stamp_ok "$1" && return 0
  apt_setup
  log "$5 (Debian bookworm)"
  (cd "$CACHE/debs" && private_apt download -t bookworm "$2" >/dev/null)
  local deb; deb=$(ls -t "$CACHE/debs/${2}_"$3*.deb | head -1)
  rm -rf "$DEPS/$1-tmp"; dpkg-deb -x "$deb" "$DEPS/$1-tmp"
  rm -rf "${DEPS:?}/$1"; mkdir -p "$DEPS/$1/include"
  cp -r "$DEPS/$1-tmp/usr/include/$4" "$DEPS/$1/include/"
  rm -rf "$DEPS/$1-tmp"
  stamp_set "$1"
}

install_glm() { install_headers glm libglm-dev 0.9 glm "GLM headers"; }
install_json() { install_headers json nlohmann-json3-dev 3 nlohmann "nlohmann/json headers"; }

install_catch2() {
  stamp_ok catch2 && return 0
  apt_setup
  log "Catch2 $CATCH2_VERSION amalgamated source (Debian trixie source package)"
  local tarball=$CACHE/catch2_$CATCH2_VERSION.orig.tar.gz
  if [ ! -f "$tarball" ]; then
    (cd "$CACHE" && private_apt source --download-only catch2 >/dev/null 2>&1 || true)
    [ -f "$tarball" ] || { echo "deps: could not download catch2 source" >&2; exit 1; }
  fi
  rm -rf "$DEPS/catch2"; mkdir -p "$DEPS/catch2"
  tar -xzf "$tarball" -C "$DEPS/catch2" --strip-components=1 \
    "Catch2-$CATCH2_VERSION/extras/catch_amalgamated.cpp" "Catch2-$CATCH2_VERSION/extras/catch_amalgamated.hpp"
  stamp_set catch2
}

# clang 14 with libFuzzer and AddressSanitizer (tests/fuzz, bench/fuzz.sh), from
# Debian bookworm into .deps/clang-root. An extracted clang cannot simply be
# run: its libLLVM / libclang-cpp (and their libz3, libxml2, libicu...) are
# not on a fresh Debian 12 machine's library path, and LD_LIBRARY_PATH into
# the extracted tree would also put its glibc under the host's loader. So,
# as for Godot, the wrapper runs it with the tree's own loader and
# libraries; --argv0 keeps the clang++ driver mode, -no-canonical-prefixes
# makes clang find its resource folder (headers, libclang_rt.fuzzer/asan)
# beside that path rather than beside the loader (/proc/self/exe). The
# programs clang starts (the linker ld of the host's binutils) and the
# fuzzers it builds run with the host's own libraries, as g++'s would; the
# C++ headers and crt files are the host's GCC 12 (install_host_tools).
install_clang() {
  stamp_ok clang && return 0
  apt_setup
  log "clang 14, libFuzzer, compiler-rt (Debian bookworm) into .deps/clang-root (about 450 MB, cached)"
  rm -rf "$DEPS/clang-root"
  extract_debs "$DEPS/clang-root" -t bookworm clang-14 libclang-common-14-dev libclang-rt-14-dev libfuzzer-14-dev
  local r=$DEPS/clang-root
  for tool in clang clang++; do
    cat > "$DEPS/bin/$tool-14" <<WRAP
#!/bin/sh
# Debian bookworm's clang 14 with its own loader and libraries (scripts/deps.sh install_clang).
R="$r"
exec "\$R/lib64/ld-linux-x86-64.so.2" --library-path "\$R/usr/lib/x86_64-linux-gnu:\$R/lib/x86_64-linux-gnu" \\
  --argv0 "\$R/usr/lib/llvm-14/bin/$tool" "\$R/usr/lib/llvm-14/bin/clang" -no-canonical-prefixes "\$@"
WRAP
    chmod +x "$DEPS/bin/$tool-14"
  done
  # A fuzzer that builds and runs proves the whole chain (driver, runtimes, linker).
  local probe=$DEPS/clang-probe
  mkdir -p "$probe"
  printf '%s\n' '#include <cstddef>' '#include <cstdint>' \
    'extern "C" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }' > "$probe/probe.cpp"
  "$DEPS/bin/clang++-14" -fsanitize=fuzzer,address "$probe/probe.cpp" -o "$probe/probe" &&
    "$probe/probe" -runs=10 >/dev/null 2>&1 ||
    { echo "deps: the extracted clang 14 cannot build and run a libFuzzer program (see above)" >&2; exit 1; }
  rm -rf "$probe"
  stamp_set clang
}

install_python() {
  local req=$ROOT/export_tools/requirements.txt
  local want; want=$(sha1sum "$req" | cut -c1-12)
  [ -f "$ROOT/.venv/.req-$want" ] && return 0
  log "Python virtual environment .venv (requirements: export_tools/requirements.txt)"
  [ -x "$ROOT/.venv/bin/python" ] || python3 -m venv "$ROOT/.venv"
  "$ROOT/.venv/bin/pip" install -q -r "$req"
  "$ROOT/.venv/bin/pip" install -q --no-deps -e "$ROOT/export_tools"
  rm -f "$ROOT"/.venv/.req-*; touch "$ROOT/.venv/.req-$want"
}

# Build tools from the machine's own Debian (present on most developer
# machines; installed when missing and we are root, else named).
install_host_tools() {
  local missing=()
  command -v cmake >/dev/null || missing+=(cmake)
  command -v ninja >/dev/null || missing+=(ninja-build)
  command -v g++ >/dev/null || missing+=(g++)
  command -v xz >/dev/null || missing+=(xz-utils)
  command -v python3 >/dev/null || missing+=(python3)
  python3 -c 'import ensurepip, venv' 2>/dev/null || missing+=(python3-venv)
  python3 -m pip --version >/dev/null 2>&1 || missing+=(python3-pip)
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -eq 0 ]; then
    log "installing build tools: ${missing[*]}"
    apt-get update -q >/dev/null && apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "deps: missing build tools; run: sudo apt-get install ${missing[*]}" >&2
    exit 1
  fi
}

what=${1:-all}
install_host_tools
case $what in
  all) install_godot; install_ort; install_glm; install_json; install_catch2; install_clang; install_python ;;
  # The build (scripts/build.sh) compiles the C++ tests too, so Catch2 is
  # part of what the demo needs; the Python environment is not.
  runtime) install_godot; install_ort; install_glm; install_json; install_catch2 ;;
  # The fuzzers' compiler alone (bench/fuzz.sh).
  fuzz) install_clang ;;
  *) echo "usage: deps.sh [all|runtime|fuzz]" >&2; exit 2 ;;
esac
