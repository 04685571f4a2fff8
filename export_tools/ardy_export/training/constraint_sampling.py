"""Constraint patterns drawn from the ground truth for denoiser training (paper 3.5).

``sample_constraint_mask`` returns a 0/1 mask [frames, M] over the window frames followed by
the available future frames; the goal is the ground truth (normalized, re-centered) times
the mask. Patterns: sparse root waypoints (x, z, with or without heading), paced waypoints
(one every 1 to 3 s over the window and its future, as a game's route or the evaluation
gives them, so the next one often lies just past the window's end), dense root paths
(x, z per frame over a span, with or without heading), full-body keyframes (root, 6D
rotations, joint positions) and keyframe blocks, sparse end-effector positions and/or
rotations (hands, feet, head), foot contacts over a span, none, and mixtures of two
patterns. Frames are drawn from the window only or from window plus future.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ardy_export.models import layout as L

PATTERNS = (
    "waypoints",
    "paced_waypoints",
    "path",
    "keyframes",
    "keyframe_block",
    "end_effectors",
    "contacts",
)


@dataclass
class ConstraintSamplingConfig:
    p_none: float = 0.15
    p_mixture: float = 0.25
    p_heading: float = 0.5
    p_window_only: float = 0.5
    max_waypoints: int = 5
    max_keyframes: int = 3
    max_block: int = 8
    max_effector_frames: int = 4
    paced_spacing: tuple[int, int] = (20, 60)  # frames between paced waypoints (1-3 s)
    weights: dict[str, float] = field(
        default_factory=lambda: {
            "waypoints": 1.0,
            "path": 1.0,
            "keyframes": 1.0,
            "keyframe_block": 0.5,
            "end_effectors": 1.0,
            "contacts": 0.5,
        }
    )

    @classmethod
    def from_dict(cls, values: dict[str, object]) -> ConstraintSamplingConfig:
        known = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        return cls(**known)  # type: ignore[arg-type]


def _frames(rng: np.random.Generator, hi: int, count: int) -> np.ndarray:
    return rng.choice(hi, size=min(count, hi), replace=False)


def _apply(
    pattern: str,
    mask: np.ndarray,
    hi: int,
    rng: np.random.Generator,
    cfg: ConstraintSamplingConfig,
) -> None:
    heading = rng.random() < cfg.p_heading
    if pattern in ("waypoints", "paced_waypoints"):
        if pattern == "waypoints":
            frames = _frames(rng, hi, int(rng.integers(1, cfg.max_waypoints + 1)))
        else:
            spacing = int(rng.integers(cfg.paced_spacing[0], cfg.paced_spacing[1] + 1))
            frames = np.arange(int(rng.integers(0, spacing)), hi, spacing)
        for f in frames:
            mask[f, [0, 2]] = 1.0
            if heading:
                mask[f, L.HEADING_SLICE] = 1.0
    elif pattern == "path":
        a = int(rng.integers(0, hi))
        b = int(rng.integers(a + 1, hi + 1)) if rng.random() < 0.5 else hi
        if rng.random() < 0.3:
            a = 0
        mask[a:b, 0] = 1.0
        mask[a:b, 2] = 1.0
        if heading:
            mask[a:b, L.HEADING_SLICE] = 1.0
    elif pattern in ("keyframes", "keyframe_block"):
        if pattern == "keyframes":
            frames = _frames(rng, hi, int(rng.integers(1, cfg.max_keyframes + 1)))
        else:
            a = int(rng.integers(0, hi))
            frames = np.arange(a, min(hi, a + int(rng.integers(2, cfg.max_block + 1))))
        for f in frames:
            mask[f, L.ROOT_SLICE] = 1.0
            mask[f, L.ROT6D_SLICE] = 1.0
            mask[f, L.JOINT_POS_SLICE] = 1.0
    elif pattern == "end_effectors":
        joints = rng.choice(
            np.asarray(L.END_EFFECTORS), size=int(rng.integers(1, 4)), replace=False
        )
        what = int(rng.integers(0, 3))  # 0 position, 1 rotation, 2 both
        for f in _frames(rng, hi, int(rng.integers(1, cfg.max_effector_frames + 1))):
            for j in joints:
                if what in (0, 2):
                    mask[f, L.joint_pos_slice(int(j))] = 1.0
                if what in (1, 2):
                    mask[f, L.rot6d_slice(int(j))] = 1.0
    elif pattern == "contacts":
        a = int(rng.integers(0, hi))
        b = int(rng.integers(a + 1, hi + 1))
        mask[a:b, L.CONTACT_SLICE] = 1.0
    else:  # pragma: no cover
        raise ValueError(f"unknown constraint pattern {pattern!r}")


def sample_constraint_mask(
    window_frames: int,
    future_frames: int,
    rng: np.random.Generator,
    cfg: ConstraintSamplingConfig,
) -> np.ndarray:
    """Mask [window_frames + future_frames, M] float32 (module docstring)."""
    total = window_frames + future_frames
    mask = np.zeros((total, L.FEATURE_SIZE), np.float32)
    if rng.random() < cfg.p_none:
        return mask
    names = [p for p in PATTERNS if cfg.weights.get(p, 0.0) > 0.0]
    probs = np.asarray([cfg.weights[p] for p in names], np.float64)
    probs /= probs.sum()
    count = 2 if rng.random() < cfg.p_mixture else 1
    for name in rng.choice(names, size=count, replace=False, p=probs):
        hi = window_frames if (rng.random() < cfg.p_window_only or future_frames == 0) else total
        _apply(str(name), mask, hi, rng, cfg)
    return mask
