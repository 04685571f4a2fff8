"""The processed dataset: unpack, convert every clip to features, index, load.

``prepare`` turns the Bandai Namco archives into ``OUT/clips.npz`` (all clips' features,
float32, concatenated: ``features`` [N, 258], ``starts`` [clips + 1] row offsets, ``names``),
``OUT/index.json`` (per clip: name, dataset, content, style, take, frames, split),
``OUT/labels.json`` (per dataset: content and style names in id order),
``OUT/skeleton.json`` (the model skeleton) and ``OUT/prepare_info.json`` (what was built
from what, and the summary figures). Re-running with the same inputs and settings does no
work beyond refreshing the split column from split.json.
"""

from __future__ import annotations

import json
import multiprocessing
import shutil
import subprocess
import sys
import tarfile
import time
import warnings
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from ardy_export.data.bvh import read_bvh
from ardy_export.data.config import ContactThresholds, DataConfig, load_data_config
from ardy_export.data.contacts import (
    compute_contacts,
    contact_ratio,
    foot_skate,
    foot_skate_from_contacts,
)
from ardy_export.data.features import FEATURE_SIZE, features_from_motion, joint_velocities
from ardy_export.data.labels import parse_clip_name, read_clip_labels, read_label_names
from ardy_export.data.skeleton import default_skeleton, motion_from_bvh, resample_motion
from ardy_export.data.split import (
    SPLIT_PATH,
    Group,
    group_sentences,
    load_split,
    make_split,
    split_of,
)

PIPELINE_VERSION = 1
ARCHIVE_GLOB = "dataset-*.tar.xz"
CLIPS_FILE = "clips.npz"
INDEX_FILE = "index.json"
LABELS_FILE = "labels.json"
SKELETON_FILE = "skeleton.json"
INFO_FILE = "prepare_info.json"


@dataclass
class Clip:
    name: str
    dataset: str
    content: str
    style: str
    features: np.ndarray  # [T, 258] float32
    split: str  # "train" or "test"
    take: int = 0

    @property
    def group(self) -> Group:
        return (self.dataset, self.content, self.style)

    @property
    def frames(self) -> int:
        return int(self.features.shape[0])


def _archive_stamp(path: Path) -> list[int]:
    stat = path.stat()
    return [int(stat.st_size), int(stat.st_mtime_ns)]


def unpack_archives(source: Path, raw: Path, log: Callable[[str], None] = print) -> list[Path]:
    """Unpack every ``dataset-*.tar.xz`` of ``source`` into ``raw`` (skipped when a marker
    says the same archive was unpacked before); returns the unpacked dataset folders."""
    archives = sorted(source.glob(ARCHIVE_GLOB))
    if not archives:
        raise FileNotFoundError(
            f"no {ARCHIVE_GLOB} archives in {source}: point --source at the folder holding "
            "dataset-1.tar.xz and dataset-2.tar.xz (see shared/data/bandai/README.md)"
        )
    raw.mkdir(parents=True, exist_ok=True)
    for archive in archives:
        marker = raw / f".unpacked-{archive.name}.json"
        stamp = _archive_stamp(archive)
        if marker.is_file() and json.loads(marker.read_text()).get("stamp") == stamp:
            log(f"{archive.name}: already unpacked in {raw}")
            continue
        log(f"{archive.name}: unpacking into {raw} ...")
        start = time.perf_counter()
        tar = shutil.which("tar")
        if tar:
            subprocess.run([tar, "-xJf", str(archive), "-C", str(raw)], check=True)
        else:
            with tarfile.open(archive, "r:xz") as bundle:
                bundle.extractall(raw, filter="data")
        marker.write_text(json.dumps({"stamp": stamp}))
        log(f"{archive.name}: unpacked in {time.perf_counter() - start:.1f} s")
    return find_dataset_roots(raw)


def find_dataset_roots(raw: Path) -> list[Path]:
    """Unpacked dataset folders (holding ``data/`` and ``cfg/``) under ``raw``."""
    return sorted(p for p in raw.iterdir() if (p / "data").is_dir() and (p / "cfg").is_dir())


def convert_bvh(path: Path, fps: float, thresholds: ContactThresholds) -> np.ndarray:
    """One BVH file -> features [T, 258] float32 at ``fps``."""
    motion = resample_motion(motion_from_bvh(read_bvh(path)), fps)
    rotations, positions = motion.global_pose()
    velocities = joint_velocities(positions, fps)
    contacts = compute_contacts(positions, velocities, thresholds=thresholds)
    return features_from_motion(rotations, positions, fps, contacts)


def _convert_job(job: tuple[str, float, ContactThresholds]) -> tuple[str, np.ndarray | str]:
    path, fps, thresholds = job
    try:
        return path, convert_bvh(Path(path), fps, thresholds)
    except (OSError, ValueError) as error:
        return path, f"{type(error).__name__}: {error}"


def _write_json(path: Path, data: object) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    tmp.replace(path)


def _held_out_groups(index: list[dict[str, Any]], split_path: Path, config: DataConfig) -> set:
    if split_path.is_file():
        return load_split(split_path)
    warnings.warn(
        f"{split_path} is missing: using a split computed in memory; run "
        "'ardy-export data make-split' to write it",
        stacklevel=2,
    )
    frames = group_frames(index)
    return set(
        make_split(
            frames,
            config.split_seed,
            config.split_test_fraction,
            config.split_min_train_groups,
            group_sentences(frames),
        )
    )


def group_frames(index: list[dict[str, Any]]) -> dict[Group, int]:
    """Frames per (dataset, content, style) group of an index."""
    frames: dict[Group, int] = defaultdict(int)
    for entry in index:
        frames[(entry["dataset"], entry["content"], entry["style"])] += int(entry["frames"])
    return dict(frames)


def _directory_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.iterdir() if p.is_file())


def prepare(
    source: Path,
    out: Path,
    raw: Path,
    config: DataConfig | None = None,
    workers: int | None = None,
    force: bool = False,
    split_path: Path = SPLIT_PATH,
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Build the processed dataset (module docstring); returns the summary figures."""
    config = config or load_data_config()
    workers = config.workers if workers is None else workers
    start = time.perf_counter()
    archives = sorted(source.glob(ARCHIVE_GLOB))
    wanted = {
        "version": PIPELINE_VERSION,
        "fps": config.fps,
        "contacts": {"height": list(config.contacts.height), "speed": list(config.contacts.speed)},
        "skate_height": list(config.skate_height),
        "archives": {a.name: _archive_stamp(a) for a in archives},
    }
    out.mkdir(parents=True, exist_ok=True)
    info_path = out / INFO_FILE
    outputs = [out / CLIPS_FILE, out / INDEX_FILE, out / LABELS_FILE, out / SKELETON_FILE]
    if not force and info_path.is_file() and all(p.is_file() for p in outputs):
        info = json.loads(info_path.read_text(encoding="utf-8"))
        if info.get("inputs") == wanted:
            index_data = json.loads((out / INDEX_FILE).read_text(encoding="utf-8"))
            _refresh_split(index_data, out, split_path, config)
            log(f"{out}: up to date (use --force to rebuild)")
            return dict(info["summary"])
    roots = unpack_archives(source, raw, log)
    labels: dict[str, dict[str, list[str]]] = {}
    jobs: list[tuple[str, float, ContactThresholds]] = []
    meta: dict[str, dict[str, Any]] = {}
    skipped: list[str] = []
    for root in roots:
        files = sorted((root / "data").glob("*.json"))
        if not files:
            continue
        dataset = parse_clip_name(files[0].stem).dataset
        contents, styles = read_label_names(root)
        labels[dataset] = {"content": contents, "style": styles}
        for label_file in files:
            bvh_path = label_file.with_suffix(".bvh")
            if not bvh_path.is_file():
                warnings.warn(
                    f"{label_file.name}: no motion file {bvh_path.name}; clip skipped",
                    stacklevel=2,
                )
                skipped.append(label_file.stem)
                continue
            parts = parse_clip_name(label_file.stem)
            content, style = read_clip_labels(label_file, contents, styles)
            if (content, style) != (parts.content, parts.style):
                warnings.warn(
                    f"{label_file.name}: labels ({content}, {style}) differ from the file "
                    f"name; using the label file",
                    stacklevel=2,
                )
            meta[str(bvh_path)] = {
                "name": label_file.stem,
                "dataset": parts.dataset,
                "content": content,
                "style": style,
                "take": parts.take,
            }
            jobs.append((str(bvh_path), config.fps, config.contacts))
    results: dict[str, np.ndarray] = {}
    failures: list[str] = []
    progress = tqdm(total=len(jobs), desc="clips", unit="clip", file=sys.stderr)
    if workers > 1:
        # fork is fastest; spawn when torch is loaded (forking its threads can deadlock)
        method = "spawn" if "torch" in sys.modules else "fork"
        with multiprocessing.get_context(method).Pool(workers) as pool:
            for path, result in pool.imap_unordered(_convert_job, jobs, chunksize=16):
                _collect(path, result, results, failures)
                progress.update()
    else:
        for job in jobs:
            path, result = _convert_job(job)
            _collect(path, result, results, failures)
            progress.update()
    progress.close()
    for failure in failures:
        warnings.warn(failure, stacklevel=2)
    ordered = sorted(results, key=lambda p: meta[p]["name"])
    index = [dict(meta[p], frames=int(results[p].shape[0])) for p in ordered]
    arrays = [results[p] for p in ordered]
    starts = np.concatenate([[0], np.cumsum([a.shape[0] for a in arrays])]).astype(np.int64)
    features = np.concatenate(arrays, axis=0).astype(np.float32)
    tmp = out / (CLIPS_FILE + ".tmp.npz")
    np.savez(tmp, features=features, starts=starts, names=np.array([e["name"] for e in index]))
    tmp.replace(out / CLIPS_FILE)
    held_out = _held_out_groups(index, split_path, config)
    for entry in index:
        entry["split"] = split_of((entry["dataset"], entry["content"], entry["style"]), held_out)
    index_data = {"fps": config.fps, "feature_size": FEATURE_SIZE, "clips": index}
    _write_json(out / INDEX_FILE, index_data)
    _write_json(out / LABELS_FILE, labels)
    _write_json(out / SKELETON_FILE, default_skeleton().to_dict())
    summary = _summary(index, features, config, skipped, failures)
    summary["seconds_taken"] = round(time.perf_counter() - start, 1)
    summary["bytes"] = _directory_size(out)
    _write_json(info_path, {"inputs": wanted, "summary": summary})
    return summary


def _collect(
    path: str, result: np.ndarray | str, results: dict[str, np.ndarray], failures: list[str]
) -> None:
    if isinstance(result, str):
        failures.append(f"{path}: {result}; clip skipped")
    else:
        results[path] = result


def refresh_split(
    processed_dir: Path, split_path: Path = SPLIT_PATH, config: DataConfig | None = None
) -> None:
    """Rewrite the split column of a processed index.json from a split file."""
    processed_dir = Path(processed_dir)
    index_data = load_index(processed_dir)
    _refresh_split(index_data, processed_dir, split_path, config or load_data_config())


def _refresh_split(
    index_data: dict[str, Any], out: Path, split_path: Path, config: DataConfig
) -> None:
    index = index_data["clips"]
    held_out = _held_out_groups(index, split_path, config)
    changed = False
    for entry in index:
        split = split_of((entry["dataset"], entry["content"], entry["style"]), held_out)
        if entry.get("split") != split:
            entry["split"] = split
            changed = True
    if changed:
        _write_json(out / INDEX_FILE, index_data)


def _summary(
    index: list[dict[str, Any]],
    features: np.ndarray,
    config: DataConfig,
    skipped: list[str],
    failures: list[str],
) -> dict[str, Any]:
    per_dataset: dict[str, dict[str, int]] = {}
    for entry in index:
        d = per_dataset.setdefault(entry["dataset"], {"clips": 0, "frames": 0, "test_clips": 0})
        d["clips"] += 1
        d["frames"] += entry["frames"]
        d["test_clips"] += int(entry.get("split") == "test")
    return {
        "clips": len(index),
        "frames": int(features.shape[0]),
        "hours": round(features.shape[0] / config.fps / 3600.0, 3),
        "per_dataset": per_dataset,
        "skipped_without_motion": skipped,
        "failed": failures,
        "skate_height_based_m_per_s": round(foot_skate(features, config.skate_height), 4),
        "skate_contact_labels_m_per_s": round(foot_skate_from_contacts(features), 4),
        "contact_ratio": [round(float(r), 3) for r in contact_ratio(features)],
        "contact_thresholds": {
            "height_m": list(config.contacts.height),
            "speed_m_per_s": list(config.contacts.speed),
        },
        "skate_height_m": list(config.skate_height),
    }


def load_index(processed_dir: str | Path) -> dict[str, Any]:
    """index.json of a processed dataset."""
    path = Path(processed_dir) / INDEX_FILE
    if not path.is_file():
        raise FileNotFoundError(
            f"{path} not found: run 'ardy-export data prepare' first (or pass the folder it wrote)"
        )
    return json.loads(path.read_text(encoding="utf-8"))


def load_clips(processed_dir: str | Path, split: str | None = None) -> list[Clip]:
    """All clips (or those of one split, "train" / "test") of a processed dataset."""
    processed_dir = Path(processed_dir)
    index = load_index(processed_dir)["clips"]
    with np.load(processed_dir / CLIPS_FILE) as data:
        features = data["features"]
        starts = data["starts"]
        names = [str(n) for n in data["names"]]
    row = {name: k for k, name in enumerate(names)}
    clips = []
    for entry in index:
        if split is not None and entry["split"] != split:
            continue
        k = row[entry["name"]]
        clips.append(
            Clip(
                name=entry["name"],
                dataset=entry["dataset"],
                content=entry["content"],
                style=entry["style"],
                features=features[starts[k] : starts[k + 1]],
                split=entry["split"],
                take=int(entry.get("take", 0)),
            )
        )
    return clips


def clips_from_bvh_files(
    paths: list[Path], config: DataConfig | None = None, split: str = "train"
) -> list[Clip]:
    """Clips straight from BVH files named like the Bandai data (labels from the file names;
    handy for tests and small experiments)."""
    config = config or load_data_config()
    clips = []
    for path in paths:
        parts = parse_clip_name(Path(path).stem)
        clips.append(
            Clip(
                name=Path(path).stem,
                dataset=parts.dataset,
                content=parts.content,
                style=parts.style,
                features=convert_bvh(Path(path), config.fps, config.contacts),
                split=split,
                take=parts.take,
            )
        )
    return clips
