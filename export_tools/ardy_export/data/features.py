"""Per-frame motion features, M = 258 (design.md section 4; indices are exact).

| slice     | size | meaning                                                          |
|-----------|------|------------------------------------------------------------------|
| 0:3       | 3    | p: Hips world position                                           |
| 3:5       | 2    | cos psi, sin psi (heading)                                       |
| 5:131     | 126  | 6D global rotation of the 21 joints, joint-major, column-major   |
| 131:191   | 60   | world positions of joints 1..20 minus (p.x, 0, p.z)              |
| 191:254   | 63   | world velocities of joints 0..20 (m/s)                           |
| 254:258   | 4    | contacts Foot_L, Toes_L, Foot_R, Toes_R (0 or 1)                 |

Heading: right = horizontal projection of UpperLeg_R - UpperLeg_L, forward = up x right,
``psi = atan2(forward.x, forward.z)`` (0 faces +Z). Velocities: backward difference, forward
difference on a clip's first frame. Rotations are relative to the model's T-pose rest
(skeleton.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ardy_export.data.bvh import write_bvh
from ardy_export.data.rotations import matrix_from_rot6d, rot6d_from_matrix
from ardy_export.data.skeleton import (
    FOOT_JOINTS,
    JOINT_COUNT,
    JOINT_INDEX,
    JOINT_NAMES,
    PARENTS,
    default_skeleton,
    fk,
    local_from_global_rotations,
)

FEATURE_SIZE = 258
POS_SLICE = slice(0, 3)
HEADING_SLICE = slice(3, 5)
ROOT_SLICE = slice(0, 5)
BODY_SLICE = slice(5, 258)
ROT6D_SLICE = slice(5, 131)
JOINT_POS_SLICE = slice(131, 191)
JOINT_VEL_SLICE = slice(191, 254)
CONTACT_SLICE = slice(254, 258)
ROOT_SIZE = ROOT_SLICE.stop - ROOT_SLICE.start  # 5
BODY_SIZE = BODY_SLICE.stop - BODY_SLICE.start  # 253
CONTACT_SIZE = CONTACT_SLICE.stop - CONTACT_SLICE.start  # 4

# Named slices, in order, as the model package's feature layout lists them.
FEATURE_LAYOUT: dict[str, tuple[int, int]] = {
    "root_position": (POS_SLICE.start, POS_SLICE.stop),
    "heading": (HEADING_SLICE.start, HEADING_SLICE.stop),
    "rotation_6d": (ROT6D_SLICE.start, ROT6D_SLICE.stop),
    "joint_positions": (JOINT_POS_SLICE.start, JOINT_POS_SLICE.stop),
    "joint_velocities": (JOINT_VEL_SLICE.start, JOINT_VEL_SLICE.stop),
    "foot_contacts": (CONTACT_SLICE.start, CONTACT_SLICE.stop),
}

_UPPER_LEG_L = JOINT_INDEX["UpperLeg_L"]
_UPPER_LEG_R = JOINT_INDEX["UpperLeg_R"]

__all__ = [
    "BODY_SIZE",
    "BODY_SLICE",
    "CONTACT_SIZE",
    "CONTACT_SLICE",
    "FEATURE_LAYOUT",
    "FEATURE_SIZE",
    "FOOT_JOINTS",
    "HEADING_SLICE",
    "JOINT_NAMES",
    "JOINT_POS_SLICE",
    "JOINT_VEL_SLICE",
    "PARENTS",
    "POS_SLICE",
    "ROOT_SIZE",
    "ROOT_SLICE",
    "ROT6D_SLICE",
    "features_from_motion",
    "fk",
    "heading_from_positions",
    "joint_velocities",
    "local_from_global_rotations",
    "motion_from_features",
    "pack_features",
    "positions_from_features",
    "recenter",
    "uncenter",
    "write_features_bvh",
]


def heading_from_positions(positions: np.ndarray) -> np.ndarray:
    """Heading psi [...] (radians) from joint positions [..., 21, 3]."""
    right = positions[..., _UPPER_LEG_R, :] - positions[..., _UPPER_LEG_L, :]
    # forward = up x right = (right.z, 0, -right.x)
    return np.arctan2(right[..., 2], -right[..., 0])


def joint_velocities(positions: np.ndarray, fps: float) -> np.ndarray:
    """Velocities [T, ...] by backward difference; frame 0 uses the forward difference."""
    positions = np.asarray(positions, dtype=np.float64)
    velocities = np.zeros_like(positions)
    if positions.shape[0] > 1:
        velocities[1:] = (positions[1:] - positions[:-1]) * fps
        velocities[0] = velocities[1]
    return velocities


def features_from_motion(
    global_rotations: np.ndarray,
    positions: np.ndarray,
    fps: float,
    contacts: np.ndarray | None = None,
    dtype: type = np.float32,
) -> np.ndarray:
    """Features [T, 258] from global rotations [T, 21, 3, 3] and positions [T, 21, 3] (metres).

    ``contacts`` [T, 4] (Foot_L, Toes_L, Foot_R, Toes_R); when None they are computed with
    the thresholds of configs/data.yaml (contacts.compute_contacts).
    """
    global_rotations = np.asarray(global_rotations, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)
    frames = positions.shape[0]
    if positions.shape[1:] != (JOINT_COUNT, 3) or global_rotations.shape != (
        frames,
        JOINT_COUNT,
        3,
        3,
    ):
        raise ValueError(
            f"features_from_motion: expected rotations [T, {JOINT_COUNT}, 3, 3] and positions "
            f"[T, {JOINT_COUNT}, 3], got {global_rotations.shape} and {positions.shape}"
        )
    velocities = joint_velocities(positions, fps)
    if contacts is None:
        from ardy_export.data.contacts import compute_contacts

        contacts = compute_contacts(positions, velocities)
    return pack_features(global_rotations, positions, velocities, contacts, dtype)


def pack_features(
    global_rotations: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    contacts: np.ndarray,
    dtype: type = np.float32,
) -> np.ndarray:
    """Features [T, 258] from its parts (rotations [T, 21, 3, 3], positions and velocities
    [T, 21, 3], contacts [T, 4]); the heading is computed from the positions."""
    positions = np.asarray(positions, dtype=np.float64)
    frames = positions.shape[0]
    contacts = np.asarray(contacts, dtype=np.float64)
    if contacts.shape != (frames, len(FOOT_JOINTS)):
        raise ValueError(f"pack_features: contacts must be [T, 4], got {contacts.shape}")
    root = positions[:, 0]
    psi = heading_from_positions(positions)
    planar = root * np.array([1.0, 0.0, 1.0])
    out = np.empty((frames, FEATURE_SIZE), dtype=np.float64)
    out[:, POS_SLICE] = root
    out[:, HEADING_SLICE] = np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    out[:, ROT6D_SLICE] = rot6d_from_matrix(np.asarray(global_rotations)).reshape(frames, -1)
    out[:, JOINT_POS_SLICE] = (positions[:, 1:] - planar[:, None]).reshape(frames, -1)
    out[:, JOINT_VEL_SLICE] = np.asarray(velocities).reshape(frames, -1)
    out[:, CONTACT_SLICE] = contacts
    return out.astype(dtype)


def positions_from_features(features: np.ndarray) -> np.ndarray:
    """World joint positions [..., T, 21, 3] from features [..., T, 258]."""
    f = np.asarray(features, dtype=np.float64)
    root = f[..., POS_SLICE]
    planar = root * np.array([1.0, 0.0, 1.0])
    joints = f[..., JOINT_POS_SLICE].reshape(*f.shape[:-1], JOINT_COUNT - 1, 3)
    return np.concatenate([root[..., None, :], joints + planar[..., None, :]], axis=-2)


def motion_from_features(features: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations [..., T, 21, 3, 3] (Gram-Schmidt from 6D) and world positions
    [..., T, 21, 3] from features [..., T, 258]."""
    f = np.asarray(features, dtype=np.float64)
    rot6d = f[..., ROT6D_SLICE].reshape(*f.shape[:-1], JOINT_COUNT, 6)
    return matrix_from_rot6d(rot6d), positions_from_features(f)


def recenter(features: np.ndarray, anchor_frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Translate so that the anchor frame's root sits at x = z = 0 (translation only).

    features [..., T, 258]; returns (re-centred copy, offset [..., 3] = (p.x, 0, p.z) of the
    anchor frame). Heights, heading, rotations, J (already planar-relative), velocities and
    contacts are untouched. ``uncenter`` adds the offset back.
    """
    f = np.array(features, copy=True)
    offset = f[..., anchor_frame, POS_SLICE] * np.array([1.0, 0.0, 1.0], dtype=f.dtype)
    f[..., POS_SLICE] -= offset[..., None, :]
    return f, offset


def uncenter(features: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The inverse of ``recenter``: add the planar offset [..., 3] back to the root."""
    f = np.array(features, copy=True)
    offset = np.asarray(offset, dtype=f.dtype) * np.array([1.0, 0.0, 1.0], dtype=f.dtype)
    f[..., POS_SLICE] += offset[..., None, :]
    return f


def write_features_bvh(path: str | Path, features: np.ndarray, fps: float = 20.0) -> None:
    """Write features [T, 258] as a BVH on the model skeleton (centimetres, ZXY channels; the
    rest pose is the model's T-pose) for viewing in any BVH viewer."""
    rotations, positions = motion_from_features(features)
    skeleton = default_skeleton()
    write_bvh(
        path,
        list(skeleton.names),
        np.array(skeleton.parents),
        skeleton.offsets,
        local_from_global_rotations(rotations),
        positions[:, 0],
        1.0 / fps,
        order="ZXY",
        scale=100.0,
    )


def features_from_local(
    local_rotations: np.ndarray,
    root_positions: np.ndarray,
    offsets: np.ndarray,
    fps: float,
    contacts: np.ndarray | None = None,
) -> np.ndarray:
    """Features [T, 258] from local rotations, root path and bone vectors (FK first)."""
    global_rotations, positions = fk(local_rotations, root_positions, offsets, PARENTS)
    return features_from_motion(global_rotations, positions, fps, contacts)
