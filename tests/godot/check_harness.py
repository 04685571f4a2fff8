"""The engine-test harness's own test: runner.gd run on the planted tests of
tests/godot/harness/test_planted.gd must pass and fail exactly the planted ones, for the
planted reasons, and check_log.py must flag the planted errors in the engine's output.

Usage: check_harness.py LOG STATUS (the runner's output and exit status); prints a PASS or
FAIL line per check and "N passed, N failed".
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from check_log import unexpected_errors

PLANTED = "test_planted."
# test -> (outcome, substrings its FAIL lines must hold, substrings they must not)
EXPECTED: dict[str, tuple[str, tuple[str, ...], tuple[str, ...]]] = {
    "test_pass_plain": ("PASS", (), ()),
    "test_pass_expected_error": ("PASS", (), ()),
    "test_fail_script_error": ("FAIL", ("script error: Invalid call",), ("never reached",)),
    "test_fail_script_error_after_await": ("FAIL", ("script error: ",), ("never reached",)),
    "test_fail_unexpected_error": ("FAIL", ("unexpected engine error: planted error",), ()),
    "test_fail_error_from_a_thread": (
        "FAIL",
        ("unexpected engine error: planted error from a thread",),
        (),
    ),
    "test_fail_missing_expected_error": (
        "FAIL",
        ('expected 1 error(s) containing "an error that never comes", the engine reported 0',),
        (),
    ),
    "test_fail_check": (
        "FAIL",
        ("planted failed check", "incomparable: expected 1 (int), found"),
        ("script error",),
    ),
    "test_fail_leaked_default_package": (
        "FAIL",
        ("resident memory grew by", "native memory leaked"),
        ("tracked memory grew", "the leaked package loads"),
    ),
    "test_fail_leaked_tiny_package": (
        "FAIL",
        ("resident memory grew by", "native memory leaked"),
        ("tracked memory grew", "the leaked package loads"),
    ),
}
# Two script errors, push_error() twice (one from a thread); the declared error is expected.
UNEXPECTED_ERROR_LINES = 4


def checks(log: str, status: int) -> list[tuple[bool, str]]:
    results: list[tuple[bool, str]] = []
    for test, (outcome, present, absent) in EXPECTED.items():
        name = PLANTED + test
        passed = f"PASS {name}" in log.splitlines()
        failures = [line for line in log.splitlines() if line.startswith(f"FAIL {name}: ")]
        found = "PASS" if passed and not failures else "FAIL" if failures else "missing"
        ok = found == outcome
        text = "\n".join(failures)
        ok = ok and all(p in text for p in present) and not any(a in text for a in absent)
        detail = "; ".join(f.split(": ", 1)[1] for f in failures) or "no failure"
        results.append((ok, f"{test}: expected {outcome}, got {found} ({detail})"))
    planted_fails = sum(1 for o, _, _ in EXPECTED.values() if o == "FAIL")
    planted_passes = len(EXPECTED) - planted_fails
    summary = f"{planted_passes} passed, {planted_fails} failed"
    results.append((summary in log.splitlines(), f"the runner's summary is '{summary}'"))
    results.append((status == planted_fails, f"the exit status is {planted_fails} ({status})"))
    unexpected = unexpected_errors(log)
    results.append(
        (
            len(unexpected) >= UNEXPECTED_ERROR_LINES
            and any("planted error from a thread" in line for line in unexpected)
            and any(line.startswith("SCRIPT ERROR:") for line in unexpected),
            f"check_log.py flags the planted error lines ({len(unexpected)} found)",
        )
    )
    leaks = re.findall(r"one leaked package: resident memory \+(\d+) bytes", log)
    results.append((len(leaks) == 2, f"both planted leaks were measured ({leaks} bytes)"))
    return results


def main(argv: list[str]) -> int:
    log = Path(argv[1]).read_text(encoding="utf-8", errors="replace")
    results = checks(log, int(argv[2]))
    for ok, what in results:
        print(f"{'PASS' if ok else 'FAIL'} harness: {what}", file=sys.stdout if ok else sys.stderr)
    passed = sum(ok for ok, _ in results)
    print(f"{passed} passed, {len(results) - passed} failed")
    return 0 if passed == len(results) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
