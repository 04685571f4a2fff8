#!/usr/bin/env python3
"""Writes src/unicode_tables.gen.cpp: the Unicode data the WordPiece tokenizer needs.

Run by hand, never by the build (the output is committed):

    python3 src/tools/gen_unicode_tables.py            # rewrite the file
    python3 src/tools/gen_unicode_tables.py --check    # exit 1 when the file is stale

The data comes from Python's ``unicodedata`` (its Unicode version is written into the file;
Python 3.11 has Unicode 14.0), so regenerating with the same Python gives identical bytes.
Tables (declared in src/unicode_tables.hpp):

* character classes as merged code-point ranges, the BERT normalizer's view of the general
  category: whitespace (Zs, Zl, Zp, tab, line feed, carriage return), control (Cc, Cf, Co,
  Cs except the three whitespace controls; unassigned Cn is *not* control, as in the
  HuggingFace ``tokenizers`` BertNormalizer the sentence encoder was trained with),
  punctuation (every P* category plus the ASCII ranges 33-47, 58-64, 91-96, 123-126), and
  nonspacing mark (Mn, removed by accent stripping); then the overrides of
  hf_char_class_overrides.txt (written by probe_hf_char_classes.py), where ``tokenizers``'
  older category tables disagree with ``unicodedata``, so the C++ ids match training's;
* canonical combining classes (non-zero only, merged ranges), for canonical ordering;
* canonical decomposition mappings, one level each (the runtime recurses); Hangul syllables
  are decomposed algorithmically and are not listed;
* lower-case mappings per code point (``str.lower`` of the single character: full mappings,
  so U+0130 becomes two code points; no context-dependent final sigma).
"""

from __future__ import annotations

import argparse
import sys
import unicodedata
from collections.abc import Callable
from pathlib import Path

OUTPUT = Path(__file__).resolve().parents[1] / "unicode_tables.gen.cpp"
OVERRIDES_FILE = Path(__file__).resolve().parent / "hf_char_class_overrides.txt"
MAX_CODE_POINT = 0x10FFFF
HANGUL_FIRST, HANGUL_LAST = 0xAC00, 0xD7A3

# CharClass values, as in src/unicode_tables.hpp.
WHITESPACE, CONTROL, PUNCTUATION, NONSPACING_MARK = 1, 2, 3, 4
CLASS_NAMES = {
    WHITESPACE: "kWhitespace",
    CONTROL: "kControl",
    PUNCTUATION: "kPunctuation",
    NONSPACING_MARK: "kNonspacingMark",
}
CLASS_WORDS = {
    WHITESPACE: "whitespace",
    CONTROL: "control",
    PUNCTUATION: "punctuation",
    NONSPACING_MARK: "nonspacing_mark",
}
ASCII_PUNCTUATION = frozenset([*range(33, 48), *range(58, 65), *range(91, 97), *range(123, 127)])


def read_overrides(path: Path = OVERRIDES_FILE) -> dict[int, int]:
    """{code point: class} from the overrides file (absent file: none)."""
    if not path.is_file():
        return {}
    values = {"other": 0} | {word: value for value, word in CLASS_WORDS.items()}
    out: dict[int, int] = {}
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.split()
        if len(fields) != 3 or fields[2] not in values:
            raise SystemExit(f"{path}:{number}: expected 'FIRST LAST CLASS', got {line!r}")
        for cp in range(int(fields[0], 16), int(fields[1], 16) + 1):
            out[cp] = values[fields[2]]
    return out


def char_class(cp: int, overrides: dict[int, int]) -> int:
    """The class of one code point, 0 for none of the four."""
    if cp in overrides:
        return overrides[cp]
    if cp in (0x09, 0x0A, 0x0D):
        return WHITESPACE
    category = unicodedata.category(chr(cp))
    if category in ("Zs", "Zl", "Zp"):
        return WHITESPACE
    if category in ("Cc", "Cf", "Co", "Cs"):
        return CONTROL
    if category.startswith("P") or cp in ASCII_PUNCTUATION:
        return PUNCTUATION
    if category == "Mn":
        return NONSPACING_MARK
    return 0


def merged_ranges(value_of: Callable[[int], int]) -> list[tuple[int, int, int]]:
    """[(first, last, value)] over all code points with a non-zero value, runs merged."""
    ranges: list[tuple[int, int, int]] = []
    for cp in range(MAX_CODE_POINT + 1):
        value = value_of(cp)
        if not value:
            continue
        if ranges and ranges[-1][1] == cp - 1 and ranges[-1][2] == value:
            ranges[-1] = (ranges[-1][0], cp, value)
        else:
            ranges.append((cp, cp, value))
    return ranges


def decompositions() -> list[tuple[int, int, int]]:
    """[(code point, first, second)]: canonical one-level mappings (second = 0: singleton)."""
    out = []
    for cp in range(MAX_CODE_POINT + 1):
        if HANGUL_FIRST <= cp <= HANGUL_LAST:
            continue
        mapping = unicodedata.decomposition(chr(cp))
        if not mapping or mapping.startswith("<"):
            continue
        parts = [int(part, 16) for part in mapping.split()]
        if len(parts) > 2:
            raise SystemExit(f"U+{cp:04X}: canonical decomposition of {len(parts)} code points")
        out.append((cp, parts[0], parts[1] if len(parts) == 2 else 0))
    return out


def lower_mappings() -> list[tuple[int, int, int]]:
    """[(code point, first, second)] for every code point whose lower case differs."""
    out = []
    for cp in range(MAX_CODE_POINT + 1):
        if 0xD800 <= cp <= 0xDFFF:
            continue
        lower = chr(cp).lower()
        if lower == chr(cp):
            continue
        if len(lower) > 2:
            raise SystemExit(f"U+{cp:04X}: lower case of {len(lower)} code points")
        out.append((cp, ord(lower[0]), ord(lower[1]) if len(lower) == 2 else 0))
    return out


def _rows(entries: list[str], per_line: int) -> str:
    lines = []
    for i in range(0, len(entries), per_line):
        lines.append("    " + ", ".join(entries[i : i + per_line]) + ",")
    return "\n".join(lines)


def _hex(value: int) -> str:
    return f"0x{value:X}"


def render() -> str:
    overrides = read_overrides()
    classes = merged_ranges(lambda cp: char_class(cp, overrides))
    combining = merged_ranges(lambda cp: unicodedata.combining(chr(cp)))
    decomposed = decompositions()
    lowered = lower_mappings()
    class_rows = [f"{{{_hex(a)}, {_hex(b)}, {CLASS_NAMES[v]}}}" for a, b, v in classes]
    combining_rows = [f"{{{_hex(a)}, {_hex(b)}, {v}}}" for a, b, v in combining]
    decomposition_rows = [f"{{{_hex(a)}, {_hex(b)}, {_hex(c)}}}" for a, b, c in decomposed]
    lower_rows = [f"{{{_hex(a)}, {_hex(b)}, {_hex(c)}}}" for a, b, c in lowered]
    return f"""\
// GENERATED by src/tools/gen_unicode_tables.py from Python's unicodedata
// (Unicode {unicodedata.unidata_version}) and src/tools/hf_char_class_overrides.txt
// ({len(overrides)} code points). Do not edit: change the script and run it again.
// Declarations and the meaning of each table: unicode_tables.hpp.

#include "unicode_tables.hpp"

// clang-format off
namespace ardy::unicode_tables {{

const char kUnicodeVersion[] = "{unicodedata.unidata_version}";

const ClassRange kClassRanges[] = {{
{_rows(class_rows, 4)}
}};
const size_t kClassRangeCount = sizeof(kClassRanges) / sizeof(kClassRanges[0]);

const CombiningRange kCombiningRanges[] = {{
{_rows(combining_rows, 5)}
}};
const size_t kCombiningRangeCount = sizeof(kCombiningRanges) / sizeof(kCombiningRanges[0]);

const Mapping kDecompositions[] = {{
{_rows(decomposition_rows, 4)}
}};
const size_t kDecompositionCount = sizeof(kDecompositions) / sizeof(kDecompositions[0]);

const Mapping kLowerMappings[] = {{
{_rows(lower_rows, 4)}
}};
const size_t kLowerMappingCount = sizeof(kLowerMappings) / sizeof(kLowerMappings[0]);

}}  // namespace ardy::unicode_tables
// clang-format on
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when the file is stale")
    parser.add_argument("--output", type=Path, default=OUTPUT, help="default: %(default)s")
    args = parser.parse_args(argv)
    text = render()
    if args.check:
        current = args.output.read_text(encoding="utf-8") if args.output.is_file() else ""
        if current != text:
            print(f"{args.output} is stale: run {Path(__file__).name}", file=sys.stderr)
            return 1
        return 0
    args.output.write_text(text, encoding="utf-8")
    print(f"wrote {args.output} ({len(text.encode())} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
