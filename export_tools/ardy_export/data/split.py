"""Train / test split by whole (dataset, content, style) groups.

The test set holds combinations never seen in training, while every content and every style
of a dataset keeps at least ``min_train_groups`` training groups (or all of its groups, when
it has fewer). A group and its left/right mirror image (``walk-turn-left / elderly`` and
``walk-turn-right / elderly``) are held out together, so that mirror augmentation of the
training set cannot recreate a held-out combination.

The choice is deterministic: candidate units are ordered by a SHA-256 hash of the seed and
the unit's names (independent of numpy versions and platforms) and taken greedily, in
passes that allow at most 1, 2, ... held-out groups per content and per style (so the test
set spreads over the labels), until ``test_fraction`` of the dataset's frames is held out.

Prompts are sentences, and sentences ignore the dataset and style aliases (dataset-1
``walk / masculinity`` and dataset-2 ``walk / masculine`` get the same ones). When the
groups' sentences are given, a held-out unit that shares a sentence with a training group is
returned to training after the draw (repeated until none does), so that no test prompt was
ever paired with motion in training. Returning units (rather than re-drawing) keeps every
other held-out group where it was: a model trained on the earlier split is still evaluated
only on groups it never saw. The test fraction can end below ``test_fraction``.

The result is committed as ``split.json`` next to this module;
``ardy-export data make-split`` regenerates it.
"""

from __future__ import annotations

import hashlib
import json
from collections import defaultdict
from collections.abc import Collection, Iterable, Mapping
from pathlib import Path

from ardy_export.data.labels import mirror_content

SPLIT_PATH = Path(__file__).with_name("split.json")
Group = tuple[str, str, str]  # (dataset, content, style)


def _mirror_group(group: Group) -> Group:
    return (group[0], mirror_content(group[1]), group[2])


def make_split(
    group_frames: Mapping[Group, int],
    seed: int,
    test_fraction: float,
    min_train_groups: int = 2,
    sentences: Mapping[Group, Collection[str]] | None = None,
) -> list[Group]:
    """The held-out groups (sorted) for the given groups and their frame counts; with
    ``sentences`` (each group's prompts), none shares a sentence with a training group."""
    if not 0.0 < test_fraction < 1.0:
        raise ValueError(f"test_fraction must be in (0, 1), got {test_fraction}")
    held_out: list[Group] = []
    by_dataset: dict[str, list[Group]] = defaultdict(list)
    for group in group_frames:
        by_dataset[group[0]].append(group)
    for dataset in sorted(by_dataset):
        groups = sorted(by_dataset[dataset])
        units = _units(groups, group_frames)

        def order_key(unit: tuple[Group, ...]) -> str:
            text = f"{seed}|" + "|".join("/".join(g) for g in unit)
            return hashlib.sha256(text.encode("utf-8")).hexdigest()

        units.sort(key=order_key)
        total = sum(group_frames[g] for g in groups)
        target = test_fraction * total
        train_count: dict[tuple[str, str], int] = defaultdict(int)  # ("content"|"style", name)
        for _, content, style in groups:
            train_count[("content", content)] += 1
            train_count[("style", style)] += 1
        floors = {key: min(min_train_groups, count) for key, count in train_count.items()}
        held_frames = 0
        held_per: dict[tuple[str, str], int] = defaultdict(int)  # held-out groups per label
        taken: set[tuple[Group, ...]] = set()
        # Passes with a growing cap on held-out groups per content and per style, so the
        # test set spreads over the labels instead of piling onto the first ones drawn.
        for cap in range(1, len(groups) + 1):
            if held_frames >= target:
                break
            for unit in units:
                if held_frames >= target:
                    break
                if unit in taken:
                    continue
                keys = [("content", c) for _, c, _ in unit] + [("style", s) for _, _, s in unit]
                if any(held_per[key] + keys.count(key) > cap for key in keys):
                    continue
                after = dict(train_count)
                for key in keys:
                    after[key] -= 1
                if any(after[key] < max(floors[key], 1) for key in after):
                    continue
                train_count = defaultdict(int, after)
                for key in keys:
                    held_per[key] += 1
                taken.add(unit)
                held_out.extend(unit)
                held_frames += sum(group_frames[g] for g in unit)
    if sentences is not None:
        held_out = _without_sentence_twins(held_out, group_frames, sentences)
    return sorted(held_out)


def _units(chosen: Iterable[Group], groups: Collection[Group]) -> list[tuple[Group, ...]]:
    """Groups as units that go together: a group with its mirror image when that is one of
    ``groups`` too."""
    units: list[tuple[Group, ...]] = []
    seen: set[Group] = set()
    for group in sorted(chosen):
        if group in seen:
            continue
        mirror = _mirror_group(group)
        unit = (group,) if mirror == group or mirror not in groups else (group, mirror)
        seen.update(unit)
        units.append(tuple(sorted(unit)))
    return units


def _without_sentence_twins(
    held_out: list[Group],
    group_frames: Mapping[Group, int],
    sentences: Mapping[Group, Collection[str]],
) -> list[Group]:
    held = set(held_out)
    while True:
        training_sentences = {s for g in group_frames if g not in held for s in sentences[g]}
        twins = [
            unit
            for unit in _units(held, group_frames)
            if any(s in training_sentences for g in unit for s in sentences[g])
        ]
        if not twins:
            return sorted(held)
        for unit in twins:
            held.difference_update(unit)


def group_sentences(groups: Iterable[Group]) -> dict[Group, frozenset[str]]:
    """Every sentence of each group's label (``text.sentences``, the training prompts)."""
    from ardy_export.text.sentences import sentences_for

    return {group: frozenset(sentences_for(*group)) for group in groups}


def sentence_twins(
    groups: Iterable[Group], held_out: set[Group], sentences: Mapping[Group, Collection[str]]
) -> list[tuple[Group, Group]]:
    """(held-out group, training group) pairs that share a sentence, sorted."""
    groups = set(groups)
    by_sentence: dict[str, list[Group]] = defaultdict(list)
    for group in sorted(groups - held_out):
        for sentence in sentences[group]:
            by_sentence[sentence].append(group)
    pairs = {
        (group, twin)
        for group in held_out & groups
        for sentence in sentences[group]
        for twin in by_sentence.get(sentence, [])
    }
    return sorted(pairs)


def save_split(
    held_out: Iterable[Group],
    path: Path = SPLIT_PATH,
    *,
    seed: int,
    test_fraction: float,
    min_train_groups: int,
) -> None:
    """Write split.json (stable formatting, so regeneration gives identical bytes)."""
    data = {
        "description": (
            "Held-out (dataset, content, style) groups of the test split; every other group "
            "is training data. Regenerate with: ardy-export data make-split"
        ),
        "seed": seed,
        "test_fraction": test_fraction,
        "min_train_groups": min_train_groups,
        "held_out": [list(g) for g in sorted(held_out)],
    }
    groups = ",\n".join("  " + json.dumps(g) for g in data.pop("held_out"))
    head = json.dumps(data, indent=1)[:-2]  # without the closing brace
    text = f'{head},\n "held_out": [\n{groups}\n ]\n}}\n'
    json.loads(text)  # well-formed
    Path(path).write_text(text, encoding="utf-8")


def load_split(path: Path = SPLIT_PATH) -> set[Group]:
    """The held-out groups of a split.json."""
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    return {(str(d), str(c), str(s)) for d, c, s in data["held_out"]}


def split_of(group: Group, held_out: set[Group]) -> str:
    return "test" if group in held_out else "train"


def check_split(
    groups: Iterable[Group],
    held_out: set[Group],
    sentences: Mapping[Group, Collection[str]] | None = None,
) -> list[str]:
    """Problems with a split (empty list when fine): a content or style of a dataset with no
    training group, a held-out group whose mirror image is in training, or (with
    ``sentences``) a held-out group that shares a sentence with a training group."""
    groups = set(groups)
    problems: list[str] = []
    for dataset in sorted({g[0] for g in groups}):
        mine = [g for g in groups if g[0] == dataset]
        train = [g for g in mine if g not in held_out]
        for axis, k in (("content", 1), ("style", 2)):
            missing = sorted({g[k] for g in mine} - {g[k] for g in train})
            if missing:
                problems.append(f"{dataset}: {axis} {missing} has no training group")
    for group in sorted(held_out & groups):
        mirror = _mirror_group(group)
        if mirror in groups and mirror not in held_out:
            problems.append(f"{'/'.join(group)} is held out but its mirror {mirror[1]} is not")
    if sentences is not None:
        for group, twin in sentence_twins(groups, held_out, sentences):
            problems.append(
                f"{'/'.join(group)} is held out but shares sentences with {'/'.join(twin)}"
            )
    return problems
