"""Train / test split by whole (dataset, content, style) groups."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ardy_export.data.labels import mirror_content
from ardy_export.data.split import (
    SPLIT_PATH,
    check_split,
    group_sentences,
    load_split,
    make_split,
    save_split,
    sentence_twins,
    split_of,
)
from conftest import processed_dir
from test_data_common import archive_groups

CONTENTS = [
    "walk",
    "run",
    "walk-turn-left",
    "walk-turn-right",
    "wave-left-hand",
    "wave-right-hand",
    "wave-both-hands",
    "jump",
]
STYLES = ["normal", "happy", "sad", "old", "proud", "tired"]


def synthetic_groups() -> dict[tuple[str, str, str], int]:
    groups = {}
    for d in ("dataset-a", "dataset-b"):
        for i, c in enumerate(CONTENTS):
            for k, s in enumerate(STYLES):
                if (i + k) % 5 != 0 or d == "dataset-b":  # leave some combinations out
                    groups[(d, c, s)] = 100 + 13 * i + 7 * k
    return groups


def test_split_holds_out_whole_groups_and_covers_labels_in_training() -> None:
    groups = synthetic_groups()
    held = make_split(groups, seed=3, test_fraction=0.2, min_train_groups=2)
    held_set = set(held)
    assert held == sorted(held) and len(held) == len(held_set)
    assert held_set <= set(groups)
    assert check_split(groups, held_set) == []
    for dataset in ("dataset-a", "dataset-b"):
        mine = {g: n for g, n in groups.items() if g[0] == dataset}
        train = [g for g in mine if g not in held_set]
        test = [g for g in mine if g in held_set]
        assert test, dataset
        # every content and style keeps >= 2 training groups; the test combinations are new
        for axis in (1, 2):
            for label in {g[axis] for g in mine}:
                assert sum(g[axis] == label for g in train) >= 2
        fraction = sum(mine[g] for g in test) / sum(mine.values())
        assert 0.18 <= fraction < 0.35
        # a held-out group and its mirror image go together
        for g in test:
            mirror = (g[0], mirror_content(g[1]), g[2])
            assert mirror not in mine or mirror in held_set
    assert split_of(held[0], held_set) == "test"
    assert split_of(("dataset-x", "walk", "normal"), held_set) == "train"


def test_split_returns_held_out_groups_whose_sentences_training_has() -> None:
    """Aliases share sentences: a held-out group with a training twin goes back to training,
    with its mirror, and nothing else moves."""
    groups = synthetic_groups()
    plain = make_split(groups, seed=3, test_fraction=0.2, min_train_groups=2)

    def prompts(group: tuple[str, str, str]) -> frozenset[str]:
        # "old" and "tired" are one style under two names, whatever the dataset
        style = "old" if group[2] == "tired" else group[2]
        return frozenset({f"{group[1]} {style}", f"a person {group[1]}s, {style}"})

    sentences = {g: prompts(g) for g in groups}
    twins = sentence_twins(groups, set(plain), sentences)
    assert twins, "the synthetic split should hold out some alias of a training group"
    assert check_split(groups, set(plain), sentences) != []
    held = make_split(groups, seed=3, test_fraction=0.2, min_train_groups=2, sentences=sentences)
    assert sentence_twins(groups, set(held), sentences) == []
    assert check_split(groups, set(held), sentences) == []
    assert set(held) < set(plain)
    returned = set(plain) - set(held)
    for group, _ in twins:
        assert group in returned
        mirror = (group[0], mirror_content(group[1]), group[2])
        assert mirror not in groups or mirror in returned
    # only twins and their mirrors go back
    twin_units = {g for g, _ in twins} | {(g[0], mirror_content(g[1]), g[2]) for g, _ in twins}
    assert returned <= twin_units


def test_split_is_deterministic(tmp_path: Path) -> None:
    groups = synthetic_groups()
    first = make_split(groups, seed=11, test_fraction=0.15)
    assert make_split(dict(reversed(list(groups.items()))), seed=11, test_fraction=0.15) == first
    assert make_split(groups, seed=12, test_fraction=0.15) != first
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    save_split(first, a, seed=11, test_fraction=0.15, min_train_groups=2)
    save_split(list(reversed(first)), b, seed=11, test_fraction=0.15, min_train_groups=2)
    assert a.read_bytes() == b.read_bytes()
    assert load_split(a) == set(first)


@pytest.mark.requires_data
def test_committed_split_is_valid_for_the_real_data() -> None:
    data = json.loads(SPLIT_PATH.read_text(encoding="utf-8"))
    held = load_split()
    assert len(held) == len(data["held_out"]) > 0
    groups = set(archive_groups("dataset-1")) | set(archive_groups("dataset-2"))
    assert held <= groups, sorted(held - groups)
    # no test prompt is a training prompt (style aliases and the two datasets share them)
    assert check_split(groups, held, group_sentences(groups)) == []
    for dataset in ("dataset-1", "dataset-2"):
        assert any(g[0] == dataset for g in held)


@pytest.mark.requires_prepared_data
def test_committed_split_regenerates_identically(tmp_path: Path) -> None:
    """Needs the prepared dataset (ardy-export data prepare)."""
    index_path = processed_dir() / "index.json"
    from ardy_export.data.config import load_data_config
    from ardy_export.data.dataset import group_frames

    config = load_data_config()
    index = json.loads(index_path.read_text(encoding="utf-8"))["clips"]
    frames = group_frames(index)
    held = make_split(
        frames,
        config.split_seed,
        config.split_test_fraction,
        config.split_min_train_groups,
        group_sentences(frames),
    )
    out = tmp_path / "split.json"
    save_split(
        held,
        out,
        seed=config.split_seed,
        test_fraction=config.split_test_fraction,
        min_train_groups=config.split_min_train_groups,
    )
    assert out.read_bytes() == SPLIT_PATH.read_bytes()
