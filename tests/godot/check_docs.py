#!/usr/bin/env python3
"""Checks doc_classes/ against the classes the engine really registered.

The engine writes the XML skeleton of every extension class (`--doctool
--gdextension-docs`); each method, member, signal and their signatures must
match our editor help, and every entry of ours must have a description.
Counts as one test in the engine suite.
"""

from __future__ import annotations

import sys
from pathlib import Path
from xml.etree import ElementTree


def signature(element: ElementTree.Element) -> str:
    """Everything of an entry but its description text."""
    parts = [f"{k}={v}" for k, v in sorted(element.attrib.items())]
    for child in element:
        if child.tag in ("return", "param"):
            parts.append(child.tag + ":" + ",".join(f"{k}={v}" for k, v in sorted(child.attrib.items())))
    return " ".join(parts)


def entries(root: ElementTree.Element) -> dict[str, ElementTree.Element]:
    found = {}
    for group, tag in (("methods", "method"), ("members", "member"), ("signals", "signal")):
        for element in root.findall(f"{group}/{tag}"):
            found[f"{tag} {element.get('name')}"] = element
    return found


def description(element: ElementTree.Element) -> str:
    node = element.find("description")
    text = node.text if node is not None else element.text
    return (text or "").strip()


def main() -> int:
    generated_dir, ours_dir = Path(sys.argv[1]), Path(sys.argv[2])
    passed = failed = 0

    def check(condition: bool, what: str) -> None:
        nonlocal passed, failed
        if condition:
            passed += 1
        else:
            failed += 1
            print(f"FAIL docs: {what}", file=sys.stderr)

    generated_files = sorted(generated_dir.glob("*.xml"))
    check(bool(generated_files), f"the engine generated class docs in {generated_dir}")
    for generated_file in generated_files:
        ours_file = ours_dir / generated_file.name
        check(ours_file.is_file(), f"doc_classes/{generated_file.name} exists")
        if not ours_file.is_file():
            continue
        generated = ElementTree.parse(generated_file).getroot()
        ours = ElementTree.parse(ours_file).getroot()
        name = generated.get("name")
        check(ours.get("inherits") == generated.get("inherits"), f"{name} inherits")
        for part in ("brief_description", "description"):
            check(bool((ours.findtext(part) or "").strip()), f"{name} has a {part}")
        registered, documented = entries(generated), entries(ours)
        for key, element in registered.items():
            mine = documented.get(key)
            check(mine is not None, f"{name}: {key} is documented")
            if mine is not None:
                check(signature(mine) == signature(element), f"{name}: {key} signature matches the engine's")
                check(bool(description(mine)), f"{name}: {key} has a description")
        for key in documented.keys() - registered.keys():
            check(False, f"{name}: {key} is documented but not registered")
    print(f"docs: {passed} checks passed, {failed} failed")
    # One test for the suite's count: the help matches the registered classes.
    print("1 passed, 0 failed" if failed == 0 else "0 passed, 1 failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
