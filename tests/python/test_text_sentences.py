"""The sentence grammar: coverage, exact laterality, mirror symmetry, determinism (no torch)."""

from __future__ import annotations

import hashlib
import random
import re
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from ardy_export.cli import main as cli_main
from ardy_export.text import sentences as S

MIN_SENTENCES = 20

DATASET_1_CONTENTS = [
    *("walk", "run", "dash", "walk-back", "walk-left", "walk-right", "bow", "bye", "guide"),
    *("byebye", "respond", "call", "punch", "kick", "slash", "dance-long", "dance-short"),
]
DATASET_1_STYLES = [
    *("normal", "happy", "sad", "angry", "proud", "not-confident", "masculinity", "feminine"),
    *("childish", "old", "tired", "active", "musical", "giant", "chimpira"),
]
DATASET_2_CONTENTS = [
    *("walk", "walk-turn-left", "walk-turn-right", "run", "wave-both-hands", "wave-left-hand"),
    *("wave-right-hand", "raise-up-both-hands", "raise-up-left-hand", "raise-up-right-hand"),
]
DATASET_2_STYLES = ["active", "elderly", "exhausted", "feminine", "masculine", "normal", "youthful"]

ALL = S.all_sentences()


def test_labels_are_the_datasets_labels() -> None:
    d1 = S.labels("dataset-1")
    d2 = S.labels("dataset-2")
    assert {(lab.content, lab.style) for lab in d1} == {
        (c, s) for c in DATASET_1_CONTENTS for s in DATASET_1_STYLES
    }
    assert {(lab.content, lab.style) for lab in d2} == {
        (c, s) for c in DATASET_2_CONTENTS for s in DATASET_2_STYLES
    }
    assert len(ALL) == len(d1) + len(d2) == 17 * 15 + 10 * 7


def test_every_label_has_many_distinct_sentences() -> None:
    for label, sentences in ALL.items():
        assert len(set(sentences)) == len(sentences), f"{label}: duplicates"
        assert len(sentences) >= MIN_SENTENCES, f"{label}: only {len(sentences)} sentences"
        for sentence in sentences:
            assert sentence == " ".join(sentence.split()), f"{label}: spacing in {sentence!r}"
            assert sentence == sentence.lower() and not sentence.endswith((".", ",")), sentence
            assert "{" not in sentence and "<" not in sentence, f"{label}: unexpanded {sentence!r}"


def test_laterality_is_exact() -> None:
    word = {side: re.compile(rf"\b{side}(wards?)?\b") for side in ("left", "right")}
    for label, sentences in ALL.items():
        sides = set(label.content.split("-")) & {"left", "right", "both"}
        for sentence in sentences:
            has_left = bool(word["left"].search(sentence))
            has_right = bool(word["right"].search(sentence))
            assert has_left == ("left" in sides), f"{label}: {sentence!r}"
            assert has_right == ("right" in sides), f"{label}: {sentence!r}"
            if "both" in sides:
                assert re.search(r"\bboth\b", sentence), f"{label}: {sentence!r} lost 'both'"


def test_mirrored_labels_exist_and_are_exact_mirror_images() -> None:
    for label, sentences in ALL.items():
        mirror = S.mirror_label(label)
        assert mirror in ALL, f"mirror {mirror} of {label} is not a label"
        assert S.mirror_label(mirror) == label
        if mirror == label:
            continue
        assert ALL[mirror] == [S.swap_sides(s) for s in sentences], f"{label} vs {mirror}"
    assert S.mirror_content("walk-turn-left") == "walk-turn-right"
    assert S.mirror_content("raise-up-both-hands") == "raise-up-both-hands"
    assert S.mirror_content("walk-back") == "walk-back"


def test_no_sentence_is_shared_by_two_labels_of_one_dataset() -> None:
    for dataset in S.datasets():
        owner: dict[str, S.Label] = {}
        for label, sentences in ALL.items():
            if label.dataset != dataset:
                continue
            for sentence in sentences:
                other = owner.setdefault(sentence, label)
                assert other == label, f"{sentence!r} is in {other} and {label}"


def test_sentences_vary_subjects_word_order_and_style() -> None:
    sentences = S.sentences_for("dataset-2", "walk-turn-left", "elderly")
    starts = {s.split()[0] for s in sentences}
    assert len(starts) >= 8, starts  # subjects, imperatives, adverbs and phrases up front
    assert any("," in s for s in sentences)
    assert any(
        s.startswith(("an old", "an elderly", "a grandmother", "a grandfather")) for s in sentences
    )
    assert any(re.search(r"\b(old|elderly|age|senior)\b", s) for s in sentences)
    phrases = defaultdict(int)
    for s in sentences:
        for verb in ("walks", "turns", "veers", "makes", "takes", "walking", "turning"):
            if verb in s.split():
                phrases[verb] += 1
    assert len(phrases) >= 5, phrases
    # Gendered subjects follow the style.
    feminine = S.sentences_for("dataset-2", "walk", "feminine")
    assert not any(re.search(r"\b(a man|a guy)\b", s) for s in feminine)
    masculine = S.sentences_for("dataset-2", "walk", "masculine")
    assert not any(re.search(r"\b(a woman|a lady)\b", s) for s in masculine)


def test_styled_labels_always_carry_their_style() -> None:
    """Only normal may have unstyled sentences: a styled label never equals a normal one."""
    normal = set(S.sentences_for("dataset-2", "run", "normal"))
    for style in DATASET_2_STYLES:
        if style != "normal":
            assert not normal & set(S.sentences_for("dataset-2", "run", style)), style


def test_canonical_prompt() -> None:
    assert (
        S.canonical_prompt("walk-turn-left", "elderly")
        == "a person walks and turns left like an elderly person"
    )
    assert S.canonical_prompt("walk", "normal") == "a person walks forward"
    assert S.canonical_prompt("walk-turn-left", "old") == S.canonical_prompt(
        "walk-turn-left", "elderly"
    )
    assert S.canonical_prompt("dataset-1_bye", "dataset-1_happy") == S.canonical_prompt(
        "bye", "happy"
    )
    for label, sentences in ALL.items():
        assert sentences[0] == S.canonical_prompt(label.content, label.style), label
    canon = {S.canonical_prompt(lab.content, lab.style) for lab in S.labels("dataset-1")}
    assert len(canon) == len(S.labels("dataset-1"))


def test_style_aliases_share_sentences() -> None:
    assert S.sentences_for(1, "walk", "masculinity") == S.sentences_for(2, "walk", "masculine")
    assert S.sentences_for("1", "run", "active") == S.sentences_for("dataset-2", "run", "active")


def test_determinism_and_count() -> None:
    first = S.sentences_for("dataset-1", "slash", "giant")
    S._expand.cache_clear()
    again = S.sentences_for("dataset-1", "slash", "giant")
    assert first == again
    assert S.sentences_for("dataset-1", "slash", "giant", count=7) == first[:7]
    assert S.sentences_for("dataset-1", "slash", "giant", count=0) == []
    a = [S.sample_sentence("dataset-2", "run", "youthful", random.Random(5)) for _ in range(3)]
    b = [S.sample_sentence("dataset-2", "run", "youthful", random.Random(5)) for _ in range(3)]
    assert a == b
    rng = np.random.default_rng(3)
    drawn = {S.sample_sentence("dataset-2", "run", "youthful", rng) for _ in range(200)}
    assert drawn <= set(S.sentences_for("dataset-2", "run", "youthful"))
    assert len(drawn) > 50


def _digest_of_everything() -> str:
    text = "\n".join(f"{label}\t{s}" for label, group in ALL.items() for s in group)
    return hashlib.sha256(text.encode()).hexdigest()


def test_same_sentences_in_a_fresh_process_with_another_hash_seed() -> None:
    code = (
        "import hashlib\n"
        "from ardy_export.text import sentences as S\n"
        "text = '\\n'.join(f'{k}\\t{s}' for k, g in S.all_sentences().items() for s in g)\n"
        "print(hashlib.sha256(text.encode()).hexdigest())\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={"PYTHONHASHSEED": "12345", "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip() == _digest_of_everything()


def test_unknown_labels_are_refused_with_the_valid_names() -> None:
    with pytest.raises(ValueError, match="walk-turn-left"):
        S.sentences_for("dataset-2", "walk-left", "normal")
    with pytest.raises(ValueError, match="youthful"):
        S.sentences_for("dataset-2", "walk", "childish")
    with pytest.raises(ValueError, match="dataset-1"):
        S.sentences_for("dataset-3", "walk", "normal")
    with pytest.raises(ValueError, match="unknown content"):
        S.canonical_prompt("fly", "normal")


def test_cfg_style_names_are_accepted() -> None:
    label = S.resolve_label("dataset-2", "dataset-2_wave-left-hand", "dataset-2_elderly")
    assert label == S.Label("dataset-2", "wave-left-hand", "elderly")


def _grammar_text() -> str:
    return (Path(S.__file__).parent / S.GRAMMAR_FILE).read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('"<wave> the left arm"', '"<wave> the right arm"', "laterality"),
        ('"<walk> leftward"', '"<walk> leftward and <hop>"', "hop"),
        ("canonical: happily", "canonical: gladly", "canonical"),
        ("post: [in a sad way,", "post: [in a sad way, on the left side,", "names a side"),
        ('  - "{subject} {v3}"\n', '  - "{subject} {v3} {vb}"\n', "exactly one"),
    ],
)
def test_grammar_rules_are_enforced(tmp_path: Path, old: str, new: str, message: str) -> None:
    text = _grammar_text()
    assert old in text
    path = tmp_path / "grammar.yaml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(S.GrammarError, match=message):
        S.load_grammar(path)


def test_cli_prints_sentences(capsys: pytest.CaptureFixture[str]) -> None:
    argv = [
        "text",
        "sentences",
        "--dataset",
        "dataset-2",
        "--content",
        "wave-right-hand",
        "--style",
        "youthful",
        "--count",
        "5",
    ]
    assert cli_main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines == S.sentences_for("dataset-2", "wave-right-hand", "youthful", count=5)
    assert (
        cli_main(
            [
                "text",
                "sentences",
                "--content",
                "bow",
                "--style",
                "sad",
                "--dataset",
                "1",
                "--canonical",
            ]
        )
        == 0
    )
    assert capsys.readouterr().out.strip() == S.canonical_prompt("bow", "sad")
