#!/usr/bin/env bash
# The Windows x86_64 build, checked under Wine: cross-builds with
# scripts/build_windows.sh when the binaries are missing (ARDY_WINDOWS_REBUILD=1
# always rebuilds), then
#   - the binaries need no MinGW runtime DLL and export what they should
#     (the GDExtension its entry symbol, ardy_c.dll every ARDY_API function);
#   - the GDExtension DLL loads under Wine and its entry refuses an empty
#     interface cleanly (tests/windows/load_gdextension.c);
#   - ardy-generate.exe under Wine on the shipped model gives the same motion
#     as the Linux ardy-generate (same seed and timeline; joint positions
#     within 1e-4 m) and the same file twice, and exits 2 on bad arguments;
#   - tests/cpp/test_c_api.c, cross-compiled against ardy_c.dll, passes.
# Prints one "PASS ..." / "FAIL ..." line per check, then "N passed, N failed";
# exits non-zero when a check fails.
#
# Usage: tests/windows/run.sh [template_debug|template_release]
# Overrides: WINE (default wine64), ARDY_LINUX_CLI (default
# build/<target>/src/ardy-generate, made by scripts/build.sh).
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
TARGET=${1:-template_debug}
BUILD=$ROOT/build/windows-$TARGET
BIN=$BUILD/bin
WORK=$BUILD/check
MODEL=$ROOT/demo_project/addons/ardy/models/default
LINUX_CLI=${ARDY_LINUX_CLI:-$ROOT/build/$TARGET/src/ardy-generate}
GDEXT_FILE=$ROOT/demo_project/addons/ardy/ardy.gdextension
TRIPLE=x86_64-w64-mingw32
GDEXT_DLL=$BIN/libardy.windows.$TARGET.x86_64.dll
SECONDS_OF_MOTION=6
SEED=7

passed=0
failed=0
pass() { echo "PASS $*"; passed=$((passed + 1)); }
fail() { echo "FAIL $*"; failed=$((failed + 1)); }
finish() {
  echo "$passed passed, $failed failed"
  [ "$failed" -eq 0 ]
  exit $?
}

# 1. Build when needed.
if [ "${ARDY_WINDOWS_REBUILD:-0}" = 1 ] || [ ! -f "$BIN/ardy-generate.exe" ] || [ ! -f "$BIN/ardy_c.dll" ] ||
  [ ! -f "$GDEXT_DLL" ] || [ ! -f "$BIN/onnxruntime.dll" ]; then
  start=$(date +%s)
  if bash "$ROOT/scripts/build_windows.sh" "$TARGET" >"$BUILD.build.log" 2>&1; then
    pass "build: scripts/build_windows.sh $TARGET ($(($(date +%s) - start)) s)"
  else
    tail -20 "$BUILD.build.log"
    fail "build: scripts/build_windows.sh $TARGET (log: $BUILD.build.log)"
    finish
  fi
fi

WINE=${WINE:-$(command -v wine64 || { [ -x /usr/lib/wine/wine64 ] && echo /usr/lib/wine/wine64; } || command -v wine || true)}
[ -n "$WINE" ] || { fail "wine: no wine64 or wine (scripts/build_windows.sh installs it)"; finish; }
# One Wine prefix (about 700 MB) for both targets.
export WINEPREFIX=${WINEPREFIX:-$ROOT/build/windows-wineprefix} WINEDEBUG=${WINEDEBUG:--all} WINEDLLOVERRIDES=${WINEDLLOVERRIDES:-mscoree,mshtml=}
if [ ! -f "$WINEPREFIX/.update-timestamp" ] || [ ! -d "$WINEPREFIX/drive_c/windows/system32" ]; then
  "$WINE" wineboot -i >"$ROOT/build/windows-wineprefix.log" 2>&1 || true
fi
mkdir -p "$WORK"

# 2. Imports: only system DLLs, msvcrt, onnxruntime.dll and ardy_c.dll.
imports_ok() {  # file -> prints the offending DLLs
  "$TRIPLE-objdump" -p "$1" | awk '/DLL Name:/ {print $3}' |
    grep -v -i -x -E 'kernel32\.dll|msvcrt\.dll|onnxruntime\.dll|ardy_c\.dll' | tr '\n' ' '
}
for f in "$BIN/ardy-generate.exe" "$BIN/ardy_c.dll" "$GDEXT_DLL"; do
  bad=$(imports_ok "$f")
  if [ -z "$bad" ]; then pass "imports: $(basename "$f") needs no MinGW runtime DLL"
  else fail "imports: $(basename "$f") also needs: $bad"; fi
done

# 3. Exports.
exports() { "$TRIPLE-objdump" -p "$1" | sed -n '/Ordinal\/Name Pointer/,/^$/p' | sed -n 's/^[[:space:]]*\[ *[0-9]*\] //p'; }
entry=$(awk -F'"' '/^entry_symbol/ {print $2}' "$GDEXT_FILE")
gd_exports=$(exports "$GDEXT_DLL" | tr '\n' ' ')
if [ -n "$entry" ] && exports "$GDEXT_DLL" | grep -qx "$entry"; then
  pass "exports: $(basename "$GDEXT_DLL") exports $entry (all: $gd_exports)"
else
  fail "exports: $(basename "$GDEXT_DLL") lacks entry symbol '$entry' (exports: $gd_exports)"
fi
want=$(grep -o 'ARDY_API[^(]*(' "$ROOT/src/ardy_c.h" | grep -o 'ardy_[a-z0-9_]*($' | tr -d '(' | sort)
have=$(exports "$BIN/ardy_c.dll" | sort)
if [ -n "$want" ] && [ "$want" = "$have" ]; then
  pass "exports: ardy_c.dll exports exactly the $(echo "$want" | wc -l) ARDY_API functions of ardy_c.h"
else
  fail "exports: ardy_c.dll differs from ardy_c.h: $(comm -3 <(echo "$want") <(echo "$have") | tr -s ' \t\n' ' ')"
fi

# The extension loads under Wine the way Godot loads it (LoadLibrary, entry
# symbol) and refuses a get_proc_address that knows no function.
if "$TRIPLE-gcc-posix" -std=c11 -O1 -Wall -Wextra -Werror -static "$ROOT/tests/windows/load_gdextension.c" \
  -o "$BIN/load_gdextension.exe" 2>"$WORK/load_gdextension.build.log"; then
  out=$("$WINE" "$BIN/load_gdextension.exe" "$GDEXT_DLL" "$entry" 2>/dev/null)
  rc=$?
  out=$(echo "$out" | tr -d '\r')
  if [ $rc -eq 0 ]; then pass "wine: $(basename "$GDEXT_DLL") $out"
  else fail "wine: loading $(basename "$GDEXT_DLL"): exit $rc: $out"; fi
else
  fail "build: tests/windows/load_gdextension.c: $(head -5 "$WORK/load_gdextension.build.log")"
fi

# 4. ardy-generate.exe under Wine against the Linux build.
cat >"$WORK/timeline.json" <<'EOF'
{
  "prompts": [{"time": 0, "text": "a person walks forward"}, {"time": 1.5, "text": "someone waves with the right hand"}],
  "constraints": [
    {"type": "waypoint", "time": 1.0, "x": 0.5, "z": 1.0, "heading": 0.3},
    {"type": "path", "start_time": 1.5, "points": [[0.5, 1.0], [0.5, 2.0]], "speed": 1.2},
    {"type": "joint", "time": 2.0, "joint": "Hand_R", "position": [0.3, 1.4, 0.2]},
    {"type": "contact", "start_time": 0.5, "end_time": 1.0, "feet": [0, 1]},
    {"type": "clicks", "start_time": 2.2, "points": [[0.5, 2.0], [1.0, 2.5], [1.5, 2.5]], "speed": 1.0}
  ]}
EOF
args=(--model "$MODEL" --timeline "$WORK/timeline.json" --seconds "$SECONDS_OF_MOTION" --seed "$SEED" --threads 1)
rm -f "$WORK/windows.json" "$WORK/windows2.json" "$WORK/linux.json"
t0=$(date +%s.%N)
"$WINE" "$BIN/ardy-generate.exe" "${args[@]}" --out-json "$WORK/windows.json" >"$WORK/windows.out" 2>"$WORK/windows.err"
rc=$?
t1=$(date +%s.%N)
wall=$(python3 -c "print(f'{$t1 - $t0:.2f}')")
if [ $rc -eq 0 ] && [ -s "$WORK/windows.json" ]; then
  pass "wine: ardy-generate.exe on the shipped model, ${SECONDS_OF_MOTION} s seed $SEED: $(tr -d '\r' <"$WORK/windows.out" | sed 's/ -> .*//') (wall ${wall} s with Wine start)"
else
  fail "wine: ardy-generate.exe exit $rc: $(tr -d '\r' <"$WORK/windows.err" | tail -3)"
fi

compare() {  # a.json b.json -> "max_position max_rotation frames_a frames_b"
  python3 - "$1" "$2" <<'PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
pos = rot = 0.0
ok = a["joints"] == b["joints"] and a["frame_count"] == b["frame_count"] and len(a["frames"]) == len(b["frames"])
for fa, fb in zip(a["frames"], b["frames"]):
    for key, acc in (("positions", "pos"), ("local_rotations", "rot")):
        d = max(abs(x - y) for ra, rb in zip(fa[key], fb[key]) for x, y in zip(ra, rb))
        if acc == "pos": pos = max(pos, d)
        else: rot = max(rot, d)
    ok = ok and fa["contacts"] == fb["contacts"]
print(f"{pos:.3g} {rot:.3g} {a['frame_count']} {b['frame_count']} {int(ok)}")
PY
}

if [ ! -x "$LINUX_CLI" ]; then
  fail "linux-vs-windows: no Linux ardy-generate at $LINUX_CLI (scripts/build.sh $TARGET, or set ARDY_LINUX_CLI)"
elif [ -s "$WORK/windows.json" ]; then
  "$LINUX_CLI" "${args[@]}" --out-json "$WORK/linux.json" >"$WORK/linux.out" 2>"$WORK/linux.err"
  if [ $? -ne 0 ]; then
    fail "linux-vs-windows: Linux ardy-generate failed: $(tail -3 "$WORK/linux.err")"
  else
    read -r dpos drot fa fb same <<<"$(compare "$WORK/linux.json" "$WORK/windows.json")"
    if [ "$same" = 1 ] && python3 -c "import sys; sys.exit(0 if $dpos < 1e-4 else 1)"; then
      pass "linux-vs-windows: $fa frames, max joint position difference $dpos m (< 1e-4), max local rotation difference $drot; Linux: $(sed 's/ -> .*//' "$WORK/linux.out")"
    else
      fail "linux-vs-windows: max joint position difference $dpos m, rotation $drot, frames $fa vs $fb, same joints/contacts: $same"
    fi
  fi
fi

if [ -s "$WORK/windows.json" ]; then
  "$WINE" "$BIN/ardy-generate.exe" "${args[@]}" --out-json "$WORK/windows2.json" >/dev/null 2>&1
  if cmp -s "$WORK/windows.json" "$WORK/windows2.json"; then
    pass "wine: the same seed gives the same JSON twice"
  else
    fail "wine: the same seed gave different JSON files"
  fi
fi

"$WINE" "$BIN/ardy-generate.exe" --model "$MODEL" --timeline "$WORK/timeline.json" --seconds 1 --bogus 3 \
  >/dev/null 2>"$WORK/usage.err"
rc=$?
if [ $rc -eq 2 ] && grep -q "unknown argument '--bogus'" "$WORK/usage.err"; then
  pass "wine: ardy-generate.exe exits 2 on a bad argument"
else
  fail "wine: ardy-generate.exe on a bad argument: exit $rc, $(tr -d '\r' <"$WORK/usage.err" | head -2)"
fi

# 5. The C ABI test, cross-compiled against ardy_c.dll.
if "$TRIPLE-gcc-posix" -std=c11 -O1 -Wall -Wextra -Werror -static -I"$ROOT/src" \
  -DARDY_TEST_DATA_DIR="\"$ROOT/tests/data\"" "$ROOT/tests/cpp/test_c_api.c" "$BUILD/src/libardy_c.dll.a" \
  -o "$BIN/test_c_api.exe" 2>"$WORK/test_c_api.build.log"; then
  out=$(cd "$ROOT" && "$WINE" "$BIN/test_c_api.exe" 2>&1)
  rc=$?
  summary=$(echo "$out" | tr -d '\r' | grep '^test_c_api:' | tail -1)
  if [ $rc -eq 0 ] && [ -n "$summary" ]; then
    pass "wine: $summary"
  else
    fail "wine: test_c_api.exe exit $rc: $(echo "$out" | tr -d '\r' | tail -5 | tr '\n' ' ')"
  fi
else
  fail "build: test_c_api.c against ardy_c.dll: $(head -5 "$WORK/test_c_api.build.log")"
fi

finish
