"""Counts the C++ suites' results by Catch2 test case, not by executable.

Usage: count_cases.py BUILD_DIR CTEST_LOG; prints "PASSED FAILED" on its last line and the
reasons for failures before it (on stderr). Per ctest test:

- a Catch2 suite (it wrote BUILD_DIR/catch2-results/NAME.xml): each TestCase in the XML is
  one test, passed when its OverallResult is a success; a suite that ctest reports failed
  with no failed test case in its XML (a crash, a sanitizer report at exit, an error outside
  any case) counts one more failure;
- a suite that wrote no XML (the C ABI test in C) counts as one test;
- a Catch2 suite with hidden test cases ("[.]", which the test command never runs) counts one
  failure per hidden case: timings belong in bench/, checks in the suite.
"""

from __future__ import annotations

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

RESULT = re.compile(r"^\s*\d+/\d+ Test\s+#\d+: (\S+) \.+\**\s*(Passed|\S.*?)\s+[\d.]+ sec$")


def ctest_results(log: str) -> dict[str, bool]:
    results: dict[str, bool] = {}
    for line in log.splitlines():
        match = RESULT.match(line)
        if match:
            results[match.group(1)] = match.group(2) == "Passed"
    return results


def hidden_cases(executable: Path) -> list[str]:
    listing = subprocess.run(
        [str(executable), "--list-tests", "[.]", "--reporter", "xml"],
        capture_output=True,
        text=True,
        check=False,
    )
    try:
        root = ET.fromstring(listing.stdout)
    except ET.ParseError:
        return [f"(cannot list the hidden test cases of {executable.name})"]
    return [(case.findtext("Name") or "?").strip() for case in root.iter("TestCase")]


def count(build: Path, log: str) -> tuple[int, int, list[str]]:
    passed = failed = 0
    problems: list[str] = []
    results = ctest_results(log)
    if not results:
        return 0, 1, ["no ctest result found in the log"]
    for name, ok in results.items():
        xml = build / "catch2-results" / f"{name}.xml"
        if not xml.is_file():
            passed, failed = passed + ok, failed + (not ok)
            if not ok:
                problems.append(f"{name}: failed")
            continue
        try:
            cases = list(ET.parse(xml).getroot().iter("TestCase"))
        except ET.ParseError:
            cases = []
        case_failures = 0
        for case in cases:
            result = case.find("OverallResult")
            if result is not None and result.get("success") == "true":
                passed += 1
            else:
                case_failures += 1
                problems.append(f"{name}: test case failed: {case.get('name')}")
        if not cases:
            problems.append(f"{name}: no test case results (it crashed or ran none)")
            case_failures = max(case_failures, 1)
        elif not ok and case_failures == 0:
            problems.append(f"{name}: failed outside its test cases (crash or sanitizer report)")
            case_failures = 1
        failed += case_failures
        executable = build / "tests" / "cpp" / name
        for hidden in hidden_cases(executable) if executable.is_file() else []:
            failed += 1
            problems.append(f"{name}: hidden test case never run: {hidden}")
    return passed, failed, problems


def main(argv: list[str]) -> int:
    build = Path(argv[1])
    log = Path(argv[2]).read_text(encoding="utf-8", errors="replace")
    passed, failed, problems = count(build, log)
    for problem in problems:
        print(f"FAIL {problem}", file=sys.stderr)
    print(f"{passed} {failed}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
