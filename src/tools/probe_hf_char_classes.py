#!/usr/bin/env python3
"""Writes src/tools/hf_char_class_overrides.txt: where HuggingFace ``tokenizers`` classifies a
code point differently from Python's ``unicodedata``.

The sentence encoder was trained on ids from the ``tokenizers`` BertNormalizer and
BertPreTokenizer, whose general-category tables are older than Python's Unicode (for example
U+0890 is a format control in Unicode 14 but unassigned there, so it is kept, not dropped).
The C++ tokenizer must give the ids training saw, so gen_unicode_tables.py applies these
overrides on top of ``unicodedata``. This script probes every code point through the installed
``tokenizers`` (a few seconds) and writes the differences as merged ranges:

    python3 src/tools/probe_hf_char_classes.py           # rewrite the file
    python3 src/tools/probe_hf_char_classes.py --check   # exit 1 when it is stale

It also checks the ranges ``tokenizers`` treats as CJK ideographs against the C++ list
(src/unicode.cpp, is_cjk_ideograph) and fails when they differ.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gen_unicode_tables as gen  # the generator's own classification

OVERRIDES = gen.OVERRIDES_FILE
# is_cjk_ideograph in src/unicode.cpp, inclusive ranges (the tokenizers crate's list: note
# 0x2B920, where BERT's original Python has 0x2B820).
CJK_RANGES = (
    (0x4E00, 0x9FFF), (0x3400, 0x4DBF), (0x20000, 0x2A6DF), (0x2A700, 0x2B73F),
    (0x2B740, 0x2B81F), (0x2B920, 0x2CEAF), (0xF900, 0xFAFF), (0x2F800, 0x2FA1F),
)  # fmt: skip


def probe() -> tuple[list[tuple[int, int, int]], list[int]]:
    """([(first, last, tokenizers' class)] where it differs from unicodedata, CJK mismatches)."""
    from tokenizers.normalizers import BertNormalizer
    from tokenizers.pre_tokenizers import BertPreTokenizer

    clean = BertNormalizer(
        clean_text=True, handle_chinese_chars=False, strip_accents=False, lowercase=False
    )
    strip = BertNormalizer(
        clean_text=False, handle_chinese_chars=False, strip_accents=True, lowercase=False
    )
    cjk = BertNormalizer(
        clean_text=False, handle_chinese_chars=True, strip_accents=False, lowercase=False
    )
    split = BertPreTokenizer()
    ranges: list[tuple[int, int, int]] = []
    cjk_mismatches: list[int] = []
    for cp in range(gen.MAX_CODE_POINT + 1):
        if 0xD800 <= cp <= 0xDFFF or cp in (0, 0xFFFD):  # surrogates; always dropped
            continue
        ch = chr(cp)
        ours = gen.char_class(cp, overrides={})
        cleaned = clean.normalize_str(f"a{ch}b")
        if cleaned == "ab":
            theirs = gen.CONTROL
        elif cleaned == "a b":
            theirs = gen.WHITESPACE
        elif len(split.pre_tokenize_str(f"a{ch}b")) == 3:
            theirs = gen.PUNCTUATION
        elif gen.unicodedata.normalize("NFD", ch) != ch:
            # Accent stripping decomposes first, so whether a decomposable code point is a
            # mark is never asked: keep unicodedata's answer.
            theirs = ours if ours == gen.NONSPACING_MARK else 0
        elif strip.normalize_str(ch) == "":
            theirs = gen.NONSPACING_MARK
        else:
            theirs = 0
        if theirs != ours:
            if ranges and ranges[-1][1] == cp - 1 and ranges[-1][2] == theirs:
                ranges[-1] = (ranges[-1][0], cp, theirs)
            else:
                ranges.append((cp, cp, theirs))
        in_list = any(first <= cp <= last for first, last in CJK_RANGES)
        if (cjk.normalize_str(ch) == f" {ch} ") != in_list:
            cjk_mismatches.append(cp)
    return ranges, cjk_mismatches


def render(ranges: list[tuple[int, int, int]]) -> str:
    import tokenizers

    lines = [
        (
            "# Code points whose BERT character class in HuggingFace tokenizers "
            f"{tokenizers.__version__}"
        ),
        f"# differs from Python's unicodedata (Unicode {gen.unicodedata.unidata_version}).",
        "# Written by probe_hf_char_classes.py, read by gen_unicode_tables.py. Do not edit.",
        "# first last class",
    ]
    names = {0: "other", **gen.CLASS_WORDS}
    lines += [f"{first:06X} {last:06X} {names[value]}" for first, last, value in ranges]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when the file is stale")
    args = parser.parse_args(argv)
    ranges, cjk_mismatches = probe()
    if cjk_mismatches:
        shown = ", ".join(f"U+{cp:04X}" for cp in cjk_mismatches[:10])
        print(f"CJK ranges differ from tokenizers at {len(cjk_mismatches)} code points: {shown}")
        return 1
    text = render(ranges)
    if args.check:
        current = OVERRIDES.read_text(encoding="utf-8") if OVERRIDES.is_file() else ""
        if current != text:
            print(f"{OVERRIDES} is stale: run {Path(__file__).name}", file=sys.stderr)
            return 1
        return 0
    OVERRIDES.write_text(text, encoding="utf-8")
    print(f"wrote {OVERRIDES} ({len(ranges)} ranges)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
