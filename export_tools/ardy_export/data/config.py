"""Data pipeline settings, read from ``export_tools/configs/data.yaml``."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from ardy_export.data.skeleton import FOOT_JOINT_NAMES

DEFAULT_CONFIG_PATH = Path(__file__).resolve().parents[2] / "configs" / "data.yaml"


@dataclass(frozen=True)
class ContactThresholds:
    """Per foot joint (Foot_L, Toes_L, Foot_R, Toes_R): height (m) and speed (m/s) limits."""

    height: tuple[float, float, float, float]
    speed: tuple[float, float, float, float]


@dataclass(frozen=True)
class DataConfig:
    source: str = "../shared/data/bandai"
    raw: str = "data/raw"
    out: str = "data/processed"
    fps: float = 20.0
    workers: int = 2
    contacts: ContactThresholds = field(
        default_factory=lambda: ContactThresholds((0.14, 0.07, 0.14, 0.07), (0.2,) * 4)
    )
    skate_height: tuple[float, float, float, float] = (0.13, 0.055, 0.13, 0.055)
    split_seed: int = 20260
    split_test_fraction: float = 0.15
    split_min_train_groups: int = 2
    norm_std_floor: float = 0.01
    norm_window_stride: int = 20
    norm_history_frames: int = 160
    norm_future_frames: int = 200
    norm_seed: int = 7
    stitch_overlap_frames: int = 6
    stitch_candidates: int = 48
    stitch_min_segment_frames: int = 30
    stitch_top_k: int = 3
    raw_dict: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)


def _per_foot(section: dict[str, Any], what: str, path: Path) -> tuple[float, float, float, float]:
    try:
        values = tuple(float(section[name]) for name in FOOT_JOINT_NAMES)
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(
            f"{path}: {what} needs a number for each of {list(FOOT_JOINT_NAMES)} ({error})"
        ) from None
    if not all(v > 0.0 for v in values):
        raise ValueError(f"{path}: {what} thresholds must be positive, found {values}")
    return values  # type: ignore[return-value]


def parse_data_config(raw: dict[str, Any], path: Path = DEFAULT_CONFIG_PATH) -> DataConfig:
    """Build a DataConfig from the YAML mapping (missing keys keep their defaults)."""
    d = DataConfig()
    contacts = raw.get("contacts", {})
    split = raw.get("split", {})
    norm = raw.get("normalization", {})
    stitch = raw.get("stitching", {})
    return DataConfig(
        source=str(raw.get("source", d.source)),
        raw=str(raw.get("raw", d.raw)),
        out=str(raw.get("out", d.out)),
        fps=float(raw.get("fps", d.fps)),
        workers=int(raw.get("workers", d.workers)),
        contacts=ContactThresholds(
            _per_foot(contacts.get("height", {}), "contacts.height", path)
            if "height" in contacts
            else d.contacts.height,
            _per_foot(contacts.get("speed", {}), "contacts.speed", path)
            if "speed" in contacts
            else d.contacts.speed,
        ),
        skate_height=_per_foot(raw["skate"]["height"], "skate.height", path)
        if "skate" in raw
        else d.skate_height,
        split_seed=int(split.get("seed", d.split_seed)),
        split_test_fraction=float(split.get("test_fraction", d.split_test_fraction)),
        split_min_train_groups=int(split.get("min_train_groups", d.split_min_train_groups)),
        norm_std_floor=float(norm.get("std_floor", d.norm_std_floor)),
        norm_window_stride=int(norm.get("window_stride", d.norm_window_stride)),
        norm_history_frames=int(norm.get("history_frames", d.norm_history_frames)),
        norm_future_frames=int(norm.get("future_frames", d.norm_future_frames)),
        norm_seed=int(norm.get("seed", d.norm_seed)),
        stitch_overlap_frames=int(stitch.get("overlap_frames", d.stitch_overlap_frames)),
        stitch_candidates=int(stitch.get("candidates", d.stitch_candidates)),
        stitch_min_segment_frames=int(
            stitch.get("min_segment_frames", d.stitch_min_segment_frames)
        ),
        stitch_top_k=int(stitch.get("top_k", d.stitch_top_k)),
        raw_dict=raw,
    )


def load_data_config(path: str | Path | None = None) -> DataConfig:
    """Read the data config (default: export_tools/configs/data.yaml; built-in defaults if
    that file is absent, e.g. in an installed, non-editable package)."""
    if path is None:
        return _load_default()
    path = Path(path)
    with path.open(encoding="utf-8") as handle:
        raw = yaml.safe_load(handle) or {}
    if not isinstance(raw, dict):
        raise ValueError(f"{path}: expected a mapping at the top level")
    return parse_data_config(raw, path)


@lru_cache(maxsize=1)
def _load_default() -> DataConfig:
    if DEFAULT_CONFIG_PATH.is_file():
        return load_data_config(DEFAULT_CONFIG_PATH)
    return DataConfig()
