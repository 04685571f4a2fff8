#!/usr/bin/env bash
# Checks the packaging scripts end to end: scripts/package_native.sh (Linux
# .tar.gz and Windows .zip) and scripts/package_addon.sh (the Godot addon zip)
# are run into a temporary folder with --no-model, and each archive's file list
# is compared with what it must hold: every expected file present, one
# top-level folder, nothing from build trees, editor caches or imports.
#
#   tests/packaging/run.sh
#     ARDY_PACKAGING_TARGET  which builds to pack (default template_debug, what
#                            scripts/test.sh builds: build/template_debug and
#                            build/windows-template_debug)
# Prints one PASS/FAIL line per check and "N passed, N failed"; exits 1 on any
# failure. Nothing is skipped: a missing Windows build is a FAIL that says so.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
TARGET=${ARDY_PACKAGING_TARGET:-template_debug}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
passed=0 failed=0
pass() { echo "PASS $*"; passed=$((passed + 1)); }
fail() { echo "FAIL $*"; failed=$((failed + 1)); }
version=$(sed -nE 's/^#define ARDY_VERSION_(MAJOR|MINOR|PATCH) ([0-9]+).*/\2/p' "$ROOT/src/ardy_c.h" | paste -sd.)

# listing ARCHIVE: its file names (no directories), one a line.
listing() {
  python3 - "$1" <<'EOF'
import sys, tarfile, zipfile
a = sys.argv[1]
if a.endswith(".zip"):
    names = [n for n in zipfile.ZipFile(a).namelist() if not n.endswith("/")]
else:
    names = [m.name for m in tarfile.open(a) if not m.isdir()]
print("\n".join(sorted(names)))
EOF
}

# check_archive LABEL ARCHIVE TOP EXPECTED... : the expected files under TOP/, one
# top-level folder, no build-tree or editor files, no model (--no-model).
check_archive() {
  local label=$1 archive=$2 top=$3; shift 3
  if [ ! -f "$archive" ]; then fail "$label: archive $archive was not written"; return; fi
  pass "$label: $(basename "$archive") written ($(du -h "$archive" | cut -f1))"
  local list=$TMP/$label.list
  listing "$archive" > "$list" || { fail "$label: cannot read $archive"; return; }
  local missing=() f
  for f in "$@"; do grep -qxF "$top/$f" "$list" || missing+=("$f"); done
  if [ ${#missing[@]} -eq 0 ]; then pass "$label: all $# expected files present"
  else fail "$label: missing ${missing[*]}"; fi
  local stray
  stray=$(grep -v "^$top/" "$list" | head -5)
  if [ -z "$stray" ]; then pass "$label: one top-level folder $top/"; else fail "$label: files outside $top/: $stray"; fi
  stray=$(grep -E '(^|/)(\.godot|CMakeFiles|build|Testing|__pycache__)/|CMakeCache\.txt|\.import$|\.o$|\.log$|\.ninja|(^|/)[^/]*[^l]\.a$|\.meta$|\.pdb$|test_c_api|load_gdextension' "$list" | head -5)
  if [ -z "$stray" ]; then pass "$label: nothing from build trees, editor caches or imports"
  else fail "$label: stray files: $stray"; fi
  if grep -q "/models/" "$list"; then fail "$label: --no-model but models/ is packed"; else pass "$label: --no-model leaves models/ out"; fi
}

# 1. package_native.sh
common=(include/ardy_c.h examples/minimal.c README.md LICENSE-model.md LICENSE-onnxruntime.txt
        csharp/README.md unity/package.json unity/README.md unity/Runtime/Ardy.Runtime.asmdef
        unity/Runtime/ArdyCharacter.cs)
for f in "$ROOT"/bindings/csharp/Ardy/*.cs; do
  common+=("csharp/Ardy/$(basename "$f")" "unity/Runtime/Ardy/$(basename "$f")")
done
platform=all
if [ ! -f "$ROOT/build/windows-$TARGET/bin/ardy_c.dll" ]; then
  fail "native windows: the Windows build is missing: build/windows-$TARGET/bin/ardy_c.dll (run: bash scripts/build_windows.sh $TARGET); only Linux is checked"
  platform=linux
fi
if bash "$ROOT/scripts/package_native.sh" --platform "$platform" --target "$TARGET" --no-model \
     --out "$TMP/native" > "$TMP/native.out" 2> "$TMP/native.err"; then
  pass "package_native.sh --platform $platform --target $TARGET --no-model exits 0"
else
  fail "package_native.sh exited non-zero: $(tail -5 "$TMP/native.err")"
fi
sed -n 's/^package_native.sh: \(.*\)/  \1/p' "$TMP/native.err" | grep -v missing || true
linux=ardy-native-$version-linux-x86_64
check_archive native-linux "$TMP/native/$linux.tar.gz" "$linux" "${common[@]}" \
  lib/libardy_c.so lib/libonnxruntime.so.1 bin/ardy-generate \
  unity/Plugins/x86_64/libardy_c.so unity/Plugins/x86_64/libonnxruntime.so.1
if grep -qxF "$TMP/native/$linux.tar.gz" "$TMP/native.out" && [ "$(tail -1 "$TMP/native.out")" = "$TMP/native/$linux.tar.gz" ]; then
  pass "native: stdout names each archive, the Linux one last"
else
  fail "native: stdout does not end with the Linux archive's path: $(cat "$TMP/native.out")"
fi
pkg_version=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["version"])' \
  "$ROOT/bindings/csharp/Unity/package.json" 2>/dev/null || echo "?")
if [ "$pkg_version" = "$version" ]; then pass "unity: package.json version $pkg_version is ardy_c.h's"
else fail "unity: package.json version $pkg_version, ardy_c.h says $version"; fi
if [ "$platform" = all ]; then
  windows=ardy-native-$version-windows-x86_64
  expected_win=("${common[@]}" lib/ardy_c.dll lib/onnxruntime.dll bin/ardy-generate.exe bin/ardy_c.dll bin/onnxruntime.dll
                unity/Plugins/x86_64/ardy_c.dll unity/Plugins/x86_64/onnxruntime.dll)
  [ -f "$ROOT/build/windows-$TARGET/src/libardy_c.dll.a" ] && expected_win+=(lib/libardy_c.dll.a)
  check_archive native-windows "$TMP/native/$windows.zip" "$windows" "${expected_win[@]}"
  if grep -qxF "$TMP/native/$windows.zip" "$TMP/native.out"; then pass "native: stdout names the Windows zip"
  else fail "native: stdout does not name $TMP/native/$windows.zip"; fi
fi

# 2. package_addon.sh
if bash "$ROOT/scripts/package_addon.sh" --no-model --out "$TMP/addon" > "$TMP/addon.out" 2> "$TMP/addon.err"; then
  pass "package_addon.sh --no-model exits 0"
else
  fail "package_addon.sh exited non-zero: $(tail -5 "$TMP/addon.err")"
fi
sed -n 's/^package_addon.sh: \(.*\)/  \1/p' "$TMP/addon.err" || true
addon=ardy-godot-$version
expected=(README.md LICENSE-model.md addons/ardy/LICENSE-model.md addons/ardy/LICENSE-onnxruntime.txt
          addons/ardy/docs/motion_generator.md addons/ardy/bin/libonnxruntime.so.1
          addons/ardy/bin/libardy.linux.$TARGET.x86_64.so)
for f in "$ROOT"/demo_project/addons/ardy/{ardy.gdextension,plugin.cfg,*.gd,*.uid}; do
  expected+=("addons/ardy/$(basename "$f")")
done
# Every library the .gdextension names that is built here, and its dependency.
for t in template_debug template_release; do
  [ -f "$ROOT/demo_project/addons/ardy/bin/libardy.linux.$t.x86_64.so" ] && expected+=(addons/ardy/bin/libardy.linux.$t.x86_64.so)
  if [ -f "$ROOT/build/windows-$t/bin/libardy.windows.$t.x86_64.dll" ]; then
    expected+=(addons/ardy/bin/libardy.windows.$t.x86_64.dll addons/ardy/bin/onnxruntime.dll)
  fi
done
if [ -f "$ROOT/build/windows-$TARGET/bin/libardy.windows.$TARGET.x86_64.dll" ]; then
  pass "addon: the Windows extension build/windows-$TARGET is there to pack"
else
  fail "addon: the Windows build is missing: build/windows-$TARGET/bin/libardy.windows.$TARGET.x86_64.dll (run: bash scripts/build_windows.sh $TARGET)"
fi
check_archive addon "$TMP/addon/$addon.zip" "$addon" "${expected[@]}"
if [ -f "$TMP/addon/$addon.zip" ]; then
  # The .gdextension's res:// paths that the zip has resolve to files in it (the libraries and their dependencies).
  bad=$(python3 - "$TMP/addon/$addon.zip" "$addon" <<'EOF'
import re, sys, zipfile
z = zipfile.ZipFile(sys.argv[1]); top = sys.argv[2]
names = set(z.namelist())
text = z.read(f"{top}/addons/ardy/ardy.gdextension").decode()
libs = dict(re.findall(r'^(\w+\.\w+\.x86_64) = "res://(.+)"$', text, re.M))
deps = dict(re.findall(r'^(\w+\.\w+\.x86_64) = \{\s*"res://([^"]+)"', text, re.M))
bad = [f"{k}: {deps[k]}" for k, v in libs.items() if f"{top}/{v}" in names and f"{top}/{deps.get(k, v)}" not in names]
print(" ".join(bad))
EOF
)
  if [ -z "$bad" ]; then pass "addon: every packed library's dependency is packed"; else fail "addon: dependencies missing: $bad"; fi
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
