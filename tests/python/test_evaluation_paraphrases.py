"""The held-out paraphrases of the evaluation (configs/paraphrases.yaml): every test label of
the split has some, and none of them is a sentence of the sentence grammar."""

from __future__ import annotations

import json
import re

import pytest

from ardy_export.evaluation import tasks
from ardy_export.text import sentences as text_sentences
from conftest import REPO_ROOT

PARAPHRASES = REPO_ROOT / "export_tools/configs/paraphrases.yaml"
SPLIT = REPO_ROOT / "export_tools/ardy_export/data/split.json"


def _normal(text: str) -> str:
    return re.sub(r"[^a-z]+", " ", text.lower()).strip()


def test_every_test_label_has_three_or_four_paraphrases() -> None:
    paraphrases = tasks.load_paraphrases(PARAPHRASES)
    held_out = {tuple(g) for g in json.loads(SPLIT.read_text())["held_out"]}
    assert held_out, "split.json lists no test labels"
    missing = sorted(held_out - set(paraphrases))
    assert not missing, f"test labels without paraphrases: {missing}"
    for group in held_out:
        own = paraphrases[group]
        assert 3 <= len(own) <= 4, group
        assert len({_normal(s) for s in own}) == len(own), f"repeated paraphrase: {group}"
    # Every key is a label of the grammar (so it can be scored against the bank).
    known = {(lab.dataset, lab.content, lab.style) for lab in text_sentences.labels()}
    assert set(paraphrases) <= known


def test_no_paraphrase_is_a_grammar_sentence() -> None:
    mine = {
        _normal(s): (group, s)
        for group, sentences in tasks.load_paraphrases(PARAPHRASES).items()
        for s in sentences
    }
    for lab in text_sentences.labels():
        for sentence in text_sentences.sentences_for(lab.dataset, lab.content, lab.style):
            hit = mine.get(_normal(sentence))
            assert hit is None, f"{hit} is a training sentence of {lab}"


def test_paraphrase_cases_score_against_the_labels_bank_sentences(tmp_path) -> None:  # noqa: ANN001
    groups = [("dataset-1", "walk", "sad"), ("dataset-1", "bow", "normal")]
    path = tmp_path / "p.yaml"
    path.write_text(
        "dataset-1/walk/sad: [a gloomy stroll, head hung low he trudges]\n"
        "dataset-1/bow/normal: [bending at the waist]\n"
    )
    cases = tasks.paraphrase_cases(groups, tasks.load_paraphrases(path), 3, 6.0, 16)
    assert [c.prompt for c in cases[:3]] == [
        "a gloomy stroll",
        "head hung low he trudges",
        "a gloomy stroll",
    ]
    # Seeds and bank sentences as the in-bank cases of the same labels: only the prompt differs.
    in_bank = tasks.text_cases(groups, 3, 6.0, 16)
    assert [c.job.seed for c in cases] == [c.job.seed for c in in_bank]
    assert [c.sentence for c in cases] == [c.sentence for c in in_bank]
    assert all(c.group == b.group for c, b in zip(cases, in_bank, strict=True))
    with pytest.raises(ValueError, match="no held-out paraphrases"):
        tasks.paraphrase_cases([("dataset-2", "walk", "normal")], {}, 1, 6.0, 16)
