"""The evaluator's motion representation: per-frame features of world joint positions that
do not change under a translation along the ground (X, Z) or a rotation about the vertical
(Y) axis.

Per frame, in the body's facing frame (forward = +Z, left = +X):

| slice               | size      | meaning                                                  |
|---------------------|-----------|----------------------------------------------------------|
| ``joints``          | 3 (J - 1) | joints 1..J-1 minus the root's ground projection (m)     |
| ``root_height``     | 1         | root height (m)                                          |
| ``root_velocity``   | 2         | root planar velocity (x, z) (m/s)                        |
| ``yaw_rate``        | 1         | turning speed of the facing direction (rad/s, + = left)  |
| ``joint_velocities``| 3 J       | world joint velocities (m/s)                             |

Facing: the sum of the hips' (UpperLeg_R - UpperLeg_L) and shoulders' (UpperArm_R -
UpperArm_L) left-to-right vectors, projected on the ground and Gaussian-smoothed over time;
forward = up x right, as ``ardy_export.data.features`` defines the heading. Velocities are
backward differences (forward difference on the first frame), as the dataset's features.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ardy_export.data.features import joint_velocities

FACING_JOINTS = (("UpperLeg_L", "UpperLeg_R"), ("UpperArm_L", "UpperArm_R"))


def canonical_layout(joint_count: int) -> dict[str, slice]:
    """Named slices of ``canonical_motion``'s feature axis for a skeleton of ``joint_count``."""
    sizes = {
        "joints": 3 * (joint_count - 1),
        "root_height": 1,
        "root_velocity": 2,
        "yaw_rate": 1,
        "joint_velocities": 3 * joint_count,
    }
    layout, start = {}, 0
    for name, size in sizes.items():
        layout[name] = slice(start, start + size)
        start += size
    return layout


def canonical_size(joint_count: int) -> int:
    """D, the feature size of ``canonical_motion`` for ``joint_count`` joints."""
    return canonical_layout(joint_count)["joint_velocities"].stop


def _smooth(x: np.ndarray, sigma_frames: float) -> np.ndarray:
    """Gaussian smoothing along axis 0, edges padded with the end values."""
    if sigma_frames <= 0.0 or x.shape[0] < 2:
        return x
    radius = max(1, math.ceil(3.0 * sigma_frames))
    kernel = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma_frames) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(x, [(radius, radius)] + [(0, 0)] * (x.ndim - 1), mode="edge")
    frames = x.shape[0]
    return sum(w * padded[i : i + frames] for i, w in enumerate(kernel))  # type: ignore[return-value]


def facing_directions(
    positions: np.ndarray, skeleton_names: Sequence[str], fps: float, smoothing_s: float = 0.1
) -> np.ndarray:
    """Unit forward vectors [T, 2] (x, z) on the ground (zero if the body lies flat)."""
    index = {name: i for i, name in enumerate(skeleton_names)}
    right = sum(positions[:, index[r]] - positions[:, index[lft]] for lft, r in FACING_JOINTS)
    forward = np.stack([right[:, 2], -right[:, 0]], axis=-1)  # up x right, (x, z)
    forward = _smooth(forward, smoothing_s * fps)
    norm = np.linalg.norm(forward, axis=-1, keepdims=True)
    return forward / np.maximum(norm, 1e-9)


def to_facing_frame(vectors: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """World (x, z) components [T, ..., 2] -> (left, forward) components in the facing frame
    of each frame (``forward`` [T, 2])."""
    fx = forward[:, 0].reshape((-1,) + (1,) * (vectors.ndim - 2))
    fz = forward[:, 1].reshape(fx.shape)
    x, z = vectors[..., 0], vectors[..., 1]
    return np.stack([x * fz - z * fx, x * fx + z * fz], axis=-1)


def canonical_motion(
    positions: np.ndarray, skeleton_names: Sequence[str], fps: float, smoothing_s: float = 0.1
) -> np.ndarray:
    """The representation [T, D] float32 of world joint positions [T, J, 3] (metres, Y up;
    joint 0 is the root); see the module docstring. ``smoothing_s``: the facing direction's
    Gaussian sigma in seconds."""
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 3 or p.shape[1] != len(skeleton_names) or p.shape[2] != 3:
        raise ValueError(
            f"canonical_motion: expected positions [T, {len(skeleton_names)}, 3], got {p.shape}"
        )
    frames, joints = p.shape[:2]
    forward = facing_directions(p, skeleton_names, fps, smoothing_s)
    planar = p[:, 1:, [0, 2]] - p[:, :1, [0, 2]]
    local = np.empty((frames, joints - 1, 3))
    local[..., [0, 2]] = to_facing_frame(planar, forward)
    local[..., 1] = p[:, 1:, 1]
    velocities = joint_velocities(p, fps)
    local_vel = np.empty_like(velocities)
    local_vel[..., [0, 2]] = to_facing_frame(velocities[..., [0, 2]], forward)
    local_vel[..., 1] = velocities[..., 1]
    turn = np.zeros(frames)
    if frames > 1:
        prev, cur = forward[:-1], forward[1:]
        cross = prev[:, 1] * cur[:, 0] - prev[:, 0] * cur[:, 1]  # + when turning towards +X
        turn[1:] = np.arctan2(cross, (prev * cur).sum(-1)) * fps
        turn[0] = turn[1]
    out = np.concatenate(
        [
            local.reshape(frames, -1),
            p[:, :1, 1],
            local_vel[:, 0, [0, 2]],
            turn[:, None],
            local_vel.reshape(frames, -1),
        ],
        axis=-1,
    )
    return out.astype(np.float32)


def centre_start(frames: int, window: int) -> int:
    """Start of the centred ``window`` of a motion of ``frames`` (0 when it is shorter)."""
    return max(0, (frames - window) // 2)


def crop_windows(
    frames: np.ndarray, starts: Sequence[int] | np.ndarray, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """Windows [N, window, D] of per-frame features [T, D] starting at ``starts`` and their
    validity masks [N, window] (bool); frames past the motion's end are zeros, masked out."""
    out = np.zeros((len(starts), window, frames.shape[1]), dtype=frames.dtype)
    mask = np.zeros((len(starts), window), dtype=bool)
    for i, start in enumerate(starts):
        if not 0 <= start < frames.shape[0]:
            raise ValueError(f"crop_windows: start {start} outside 0..{frames.shape[0] - 1}")
        piece = frames[start : start + window]
        out[i, : len(piece)] = piece
        mask[i, : len(piece)] = True
    return out, mask
