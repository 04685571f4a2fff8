"""Fails an engine run whose output has an error line that no test declared.

The engine prints every error it reports as a line starting with "ERROR:" or "SCRIPT ERROR:"
(also errors at start-up and at exit, outside any test). runner.gd prints "runner: N expected
engine errors", the errors tests declared with expect_error(); any error line beyond those is
unexpected. Usage: check_log.py LOG [WHAT]; prints "N passed, N failed" (one check).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ERROR_LINE = re.compile(r"^(SCRIPT |SHADER |USER )?ERROR:")
EXPECTED = re.compile(r"^runner: (\d+) expected engine errors$", re.MULTILINE)


def error_lines(log: str) -> list[str]:
    return [line for line in log.splitlines() if ERROR_LINE.match(line)]


def unexpected_errors(log: str) -> list[str]:
    """The error lines beyond the expected count (all of them where the log declares none)."""
    lines = error_lines(log)
    declared = EXPECTED.findall(log)
    expected = int(declared[-1]) if declared else 0
    return lines if len(lines) > expected else []


def main(argv: list[str]) -> int:
    log = Path(argv[1]).read_text(encoding="utf-8", errors="replace")
    what = argv[2] if len(argv) > 2 else argv[1]
    declared = EXPECTED.findall(log)
    expected = int(declared[-1]) if declared else 0
    lines = error_lines(log)
    if len(lines) <= expected:
        print(f"PASS {what}: {len(lines)} engine error lines, {expected} expected")
        print("1 passed, 0 failed")
        return 0
    print(
        f"FAIL {what}: {len(lines)} engine error lines, only {expected} expected by the tests:",
        file=sys.stderr,
    )
    for line in lines:
        print(f"  {line}", file=sys.stderr)
    print("0 passed, 1 failed")
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
