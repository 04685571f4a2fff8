"""src/unicode_tables.gen.cpp and its overrides are what the generators write today."""

from __future__ import annotations

import importlib.util
import sys
import unicodedata
from pathlib import Path
from types import ModuleType

import pytest

TOOLS = Path(__file__).resolve().parents[2] / "src" / "tools"


def _load(name: str) -> ModuleType:
    if str(TOOLS) not in sys.path:
        sys.path.insert(0, str(TOOLS))  # the probe imports the generator by name
    spec = importlib.util.spec_from_file_location(name, TOOLS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generated_tables_are_fresh() -> None:
    gen = _load("gen_unicode_tables")
    committed = gen.OUTPUT.read_text(encoding="utf-8")
    if f'kUnicodeVersion[] = "{unicodedata.unidata_version}"' not in committed:
        pytest.skip(
            f"this Python has Unicode {unicodedata.unidata_version}; the tables need another"
        )
    assert gen.render() == committed, (
        f"{gen.OUTPUT} is stale: run python3 src/tools/gen_unicode_tables.py"
    )


def test_tables_cover_the_expected_data() -> None:
    text = (TOOLS.parent / "unicode_tables.gen.cpp").read_text(encoding="utf-8")
    assert "{0xE9, 0x65, 0x301}" in text  # é -> e + combining acute
    assert "{0x130, 0x69, 0x307}" in text  # İ lower-cases to two code points
    assert "{0x300, 0x36F, kNonspacingMark}" in text
    assert len(text.encode()) < 300_000


def test_hf_overrides_are_fresh() -> None:
    pytest.importorskip("tokenizers")
    probe = _load("probe_hf_char_classes")
    ranges, cjk_mismatches = probe.probe()
    assert cjk_mismatches == [], "CJK ranges in src/unicode.cpp differ from tokenizers'"
    committed = probe.OVERRIDES.read_text(encoding="utf-8")
    assert probe.render(ranges) == committed, (
        f"{probe.OVERRIDES} is stale: run python3 src/tools/probe_hf_char_classes.py, then "
        "gen_unicode_tables.py"
    )
