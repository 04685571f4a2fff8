"""Per-feature normalization statistics (design.md section 4, "Normalization").

Computed over the training split after the same re-centering the runtime applies (the root's
x and z of the last history frame moved to the origin; features.recenter): for every
training clip, random anchors (one per ``window_stride`` frames), each with the frames from
``history_frames`` before to ``future_frames`` after it, re-centred on the anchor, and with
the training augmentations applied (a uniform random yaw about the anchor and a mirror half
of the time), so the statistics describe what the model sees. Only the root x/z depend on
the re-centering; everything else is the plain (augmented) per-frame distribution.

Standard deviations are clamped to at least ``std_floor`` (near-static dims, e.g. a bone's
6D component that barely moves). The four contact dims are not estimated: they use mean
0.5 and std 0.5, which maps {0, 1} to {-1, +1}.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ardy_export.data.augment import mirror_features, rotate_yaw
from ardy_export.data.features import CONTACT_SLICE, FEATURE_SIZE, recenter

if TYPE_CHECKING:
    from ardy_export.data.dataset import Clip


@dataclass
class NormalizationStats:
    mean: np.ndarray  # [258] float32
    std: np.ndarray  # [258] float32, every entry >= the floor
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.mean = np.asarray(self.mean, dtype=np.float32).reshape(-1)
        self.std = np.asarray(self.std, dtype=np.float32).reshape(-1)
        if self.mean.shape != self.std.shape:
            raise ValueError(f"mean {self.mean.shape} and std {self.std.shape} differ in shape")
        if not (np.all(np.isfinite(self.mean)) and np.all(np.isfinite(self.std))):
            raise ValueError("normalization statistics contain NaN or infinity")
        if np.any(self.std <= 0.0):
            raise ValueError("normalization std must be positive")

    def normalize(self, features: np.ndarray) -> np.ndarray:
        return (np.asarray(features) - self.mean) / self.std

    def denormalize(self, normalized: np.ndarray) -> np.ndarray:
        return np.asarray(normalized) * self.std + self.mean

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (float lists), e.g. for model.json."""
        return {
            "mean": [float(v) for v in self.mean],
            "std": [float(v) for v in self.std],
            "info": self.info,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> NormalizationStats:
        return cls(np.array(data["mean"]), np.array(data["std"]), dict(data.get("info", {})))

    def save(self, path: str | Path) -> None:
        """Write an .npz with ``mean``, ``std`` and ``info`` (JSON text)."""
        np.savez(path, mean=self.mean, std=self.std, info=np.array(json.dumps(self.info)))

    @classmethod
    def load(cls, path: str | Path) -> NormalizationStats:
        with np.load(path) as data:
            return cls(data["mean"], data["std"], json.loads(str(data["info"])))


def compute_normalization_stats(
    clips: Sequence[Clip] | Sequence[np.ndarray],
    *,
    seed: int = 7,
    window_stride: int = 20,
    history_frames: int = 160,
    future_frames: int = 200,
    std_floor: float = 0.01,
    augment: bool = True,
) -> NormalizationStats:
    """Statistics over ``clips`` (pass the training split; Clip objects or feature arrays)."""
    rng = np.random.default_rng(seed)
    total = np.zeros(FEATURE_SIZE)
    total_sq = np.zeros(FEATURE_SIZE)
    count = 0
    for clip in clips:
        features = clip if isinstance(clip, np.ndarray) else clip.features
        frames = features.shape[0]
        if frames == 0:
            continue
        for _ in range(max(1, int(np.ceil(frames / window_stride)))):
            anchor = int(rng.integers(frames))
            lo = max(0, anchor - history_frames)
            hi = min(frames, anchor + future_frames + 1)
            window = features[lo:hi].astype(np.float64)
            if augment:
                if rng.random() < 0.5:
                    window = mirror_features(window)
                window = rotate_yaw(window, float(rng.uniform(-np.pi, np.pi)), anchor - lo)
            window, _ = recenter(window, anchor - lo)
            total += window.sum(axis=0)
            total_sq += np.square(window).sum(axis=0)
            count += window.shape[0]
    if count == 0:
        raise ValueError("compute_normalization_stats: no frames")
    mean = total / count
    std = np.sqrt(np.maximum(total_sq / count - np.square(mean), 0.0))
    floored = int(np.sum(std < std_floor))
    std = np.maximum(std, std_floor)
    mean[CONTACT_SLICE] = 0.5
    std[CONTACT_SLICE] = 0.5
    info = {
        "frames": int(count),
        "clips": len(clips),
        "seed": seed,
        "window_stride": window_stride,
        "history_frames": history_frames,
        "future_frames": future_frames,
        "std_floor": std_floor,
        "floored_dims": floored,
        "augment": "mirror 50%, uniform yaw" if augment else "none",
        "recenter": "translation only, anchor frame's root x/z to the origin",
        "contacts": "mean 0.5, std 0.5",
    }
    return NormalizationStats(mean, std, info)
