"""Fails an editor run whose log has an error the ARDY addon (or the editor test) caused.

The engine prints each error as a line starting with "ERROR:" or "SCRIPT ERROR:", followed by
indented "at: ..." and "GDScript backtrace" lines that name the script and C++ source. An error
counts when any line of its block names res://addons/ardy (the plugin, the dock, the extension's
files) or the test plugin; every SCRIPT ERROR counts. Usage: check_editor_log.py LOG; prints the
errors found and exits 1 when there are any.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ERROR_LINE = re.compile(r"^(SCRIPT |SHADER |USER )?ERROR:")
OURS = re.compile(r"addons/ardy|ardy_editor_test")


def error_blocks(log: str) -> list[list[str]]:
    """Each error line with the indented lines under it."""
    blocks: list[list[str]] = []
    current: list[str] | None = None
    for line in log.splitlines():
        if ERROR_LINE.match(line):
            current = [line]
            blocks.append(current)
        elif current is not None and (line.startswith((" ", "\t")) or not line.strip()):
            if line.strip():
                current.append(line)
        else:
            current = None
    return blocks


def ours(block: list[str]) -> bool:
    return block[0].startswith("SCRIPT ERROR:") or any(
        OURS.search(line) for line in block
    )


def main(argv: list[str]) -> int:
    log = Path(argv[1]).read_text(encoding="utf-8", errors="replace")
    blocks = error_blocks(log)
    found = [block for block in blocks if ours(block)]
    others = len(blocks) - len(found)
    if others:
        print(
            f"editor log: {others} engine error(s) not from the ARDY addon (not counted)"
        )
    if not found:
        print("editor log: no errors from the ARDY addon")
        return 0
    print(f"editor log: {len(found)} error(s) from the ARDY addon:", file=sys.stderr)
    for block in found:
        for line in block:
            print(f"  {line}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
