"""Shared helpers of the data pipeline tests: a handful of real Bandai Namco clips.

The clips are extracted once from the archives in ``conftest.bandai_dir()`` (the one place
that decides where they are) into ``data/test_cache/bandai`` (git-ignored) and reused by later
runs; only the needed members are extracted. Tests that need them carry
``@pytest.mark.requires_data`` (skipped without the archives, failed with
ARDY_REQUIRE_DATA=1; see conftest.py). This module holds no tests itself.
"""

from __future__ import annotations

import shutil
import subprocess
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from ardy_export.data.config import load_data_config
from ardy_export.data.dataset import Clip, clips_from_bvh_files
from conftest import bandai_dir, require

REPO_ROOT = Path(__file__).resolve().parents[2]
CACHE_DIR = REPO_ROOT / "data" / "test_cache" / "bandai"

CLIP_NAMES: dict[str, tuple[str, ...]] = {
    "dataset-1": (
        "dataset-1_walk_normal_002",  # joint_Root carries a translation in this one
        "dataset-1_run_normal_001",  # and in this one
        "dataset-1_walk-left_normal_001",
        "dataset-1_walk-right_normal_001",
        "dataset-1_bow_active_001",
    ),
    "dataset-2": (
        "dataset-2_walk_normal_001",
        "dataset-2_walk-turn-left_normal_001",
        "dataset-2_walk-turn-right_normal_001",
        "dataset-2_wave-left-hand_normal_001",
        "dataset-2_run_normal_001",
    ),
}
# A label file whose motion file is missing from the data (README): prepare must skip it.
LABEL_ONLY = "dataset-1_dance-long_normal_001"


def _folder(dataset: str) -> str:
    return f"Bandai-Namco-Research-Motiondataset-{dataset.split('-')[1]}"


def _archive(dataset: str) -> Path:
    return bandai_dir() / f"{dataset}.tar.xz"


def _members(dataset: str) -> list[str]:
    folder = _folder(dataset)
    members = [f"{folder}/cfg/content_label.txt", f"{folder}/cfg/style_label.txt"]
    for name in CLIP_NAMES[dataset]:
        members += [f"{folder}/data/{name}.bvh", f"{folder}/data/{name}.json"]
    if dataset == "dataset-1":
        members.append(f"{folder}/data/{LABEL_ONLY}.json")
    return members


@lru_cache(maxsize=1)
def real_data_dir() -> Path | None:
    """The cache folder with the test clips extracted, or None without the archives."""
    if not all(_archive(d).is_file() for d in CLIP_NAMES) or shutil.which("tar") is None:
        return None
    for dataset in CLIP_NAMES:
        members = _members(dataset)
        missing = [m for m in members if not (CACHE_DIR / m).is_file()]
        if missing:
            CACHE_DIR.mkdir(parents=True, exist_ok=True)
            subprocess.run(
                ["tar", "-xJf", str(_archive(dataset)), "-C", str(CACHE_DIR), *missing],
                check=True,
            )
    return CACHE_DIR


def require_real_data() -> Path:
    require("requires_data")  # skips or fails the test (conftest.py) without the archives
    root = real_data_dir()
    if root is None:
        pytest.fail("tar is needed to extract the test clips from the Bandai Namco archives")
    return root


def dataset_root(dataset: str) -> Path:
    return require_real_data() / _folder(dataset)


def clip_path(name: str) -> Path:
    dataset = name.split("_")[0]
    return dataset_root(dataset) / "data" / f"{name}.bvh"


def all_clip_paths() -> list[Path]:
    return [clip_path(n) for names in CLIP_NAMES.values() for n in names]


@lru_cache(maxsize=1)
def _real_clips() -> tuple[Clip, ...]:
    return tuple(clips_from_bvh_files(all_clip_paths(), load_data_config()))


def real_clips() -> list[Clip]:
    """The test clips converted to features (20 fps), computed once per session."""
    require_real_data()
    return [
        Clip(c.name, c.dataset, c.content, c.style, c.features.copy(), c.split, c.take)
        for c in _real_clips()
    ]


@lru_cache(maxsize=2)
def archive_groups(dataset: str) -> tuple[tuple[str, str, str], ...]:
    """(dataset, content, style) of every BVH in an archive (listing cached on disk)."""
    from ardy_export.data.labels import parse_clip_name

    require_real_data()
    listing = CACHE_DIR / f"members-{dataset}.txt"
    if not listing.is_file():
        names = subprocess.run(
            ["tar", "-tJf", str(_archive(dataset))], check=True, capture_output=True, text=True
        ).stdout
        listing.write_text(names, encoding="utf-8")
    groups = set()
    for line in listing.read_text(encoding="utf-8").splitlines():
        if line.endswith(".bvh"):
            parts = parse_clip_name(Path(line).stem)
            groups.add((parts.dataset, parts.content, parts.style))
    return tuple(sorted(groups))


def naive_bvh_positions(path: Path) -> tuple[list[str], np.ndarray]:
    """Joint names and world positions [F, J, 3] (file units) of a BVH, computed
    independently of the package: a plain parse and a 4x4 matrix chain per joint and frame."""
    tokens = path.read_text(encoding="utf-8").split()
    names: list[str] = []
    parents: list[int] = []
    channels: list[list[str]] = []
    stack: list[int] = []
    i = 0
    last = -1
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            channels.append([])
            last = len(names) - 1
            i += 2
        elif t == "End":
            last = -2
            i += 2
        elif t == "{":
            stack.append(last)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            channels[stack[-1]] = tokens[i + 2 : i + 2 + n]
            i += 2 + n
        elif t == "OFFSET":
            i += 4
        else:
            i += 1
    frames = int(tokens[i + 2])
    values = np.array(tokens[i + 6 :], dtype=np.float64).reshape(frames, -1)

    def axis(letter: str, degrees: float) -> np.ndarray:
        a = np.radians(degrees)
        c, s = np.cos(a), np.sin(a)
        m = np.eye(4)
        k = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[letter]
        m[k[0], k[0]], m[k[0], k[1]], m[k[1], k[0]], m[k[1], k[1]] = c, -s, s, c
        return m

    out = np.zeros((frames, len(names), 3))
    for f in range(frames):
        world: list[np.ndarray] = []
        column = 0
        for j in range(len(names)):
            local = np.eye(4)
            rotation = np.eye(4)
            for name in channels[j]:
                v = values[f, column]
                column += 1
                if name.endswith("position"):
                    local[{"X": 0, "Y": 1, "Z": 2}[name[0]], 3] = v
                else:
                    rotation = rotation @ axis(name[0], v)
            local = local @ rotation
            world.append(local if parents[j] < 0 else world[parents[j]] @ local)
            out[f, j] = world[j][:3, 3]
    return names, out
