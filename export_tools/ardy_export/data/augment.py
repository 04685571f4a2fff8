"""Augmentation: left/right mirror and yaw rotation of whole feature sequences.

Mirror (reflection across the YZ plane, S = diag(-1, 1, 1), with _L and _R joints swapped):
positions and velocities ``x -> S x_mirror(j)``, rotations ``R -> S R_mirror(j) S`` (exact
for the model skeleton because its rest pose is symmetric; skeleton.py), heading
``psi -> -psi`` (what the heading definition gives for the mirrored hips), contacts swap
feet. On the features this is a signed permutation, so mirroring twice is exactly the
identity; ``mirror_permutation_and_signs`` exposes it for use on tensors.

Labels swap left and right (labels.py): walk-left <-> walk-right, walk-turn-left <->
walk-turn-right, wave-left-hand <-> wave-right-hand, raise-up-left-hand <->
raise-up-right-hand; symmetric contents and all styles stay.

Yaw: rotation of the whole sequence about the world +Y axis (through the origin, or through
a pivot frame's root): positions, J (planar-relative, so rotated as vectors), velocities and
global rotations (``R -> Y R``) rotate; the heading grows by the angle; heights and
contacts are unchanged.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from ardy_export.data.features import (
    CONTACT_SLICE,
    FEATURE_SIZE,
    HEADING_SLICE,
    JOINT_POS_SLICE,
    JOINT_VEL_SLICE,
    POS_SLICE,
    ROT6D_SLICE,
)
from ardy_export.data.labels import mirror_content, mirror_style
from ardy_export.data.rotations import yaw_matrix
from ardy_export.data.skeleton import JOINT_COUNT, MIRROR_CONTACTS, MIRROR_JOINTS

if TYPE_CHECKING:
    from ardy_export.data.dataset import Clip

MIRROR_SUFFIX = "_mirror"


@lru_cache(maxsize=1)
def mirror_permutation_and_signs() -> tuple[np.ndarray, np.ndarray]:
    """(index [258], sign [258]) with ``mirrored = features[..., index] * sign``."""
    index = np.arange(FEATURE_SIZE)
    sign = np.ones(FEATURE_SIZE)
    reflect = np.array([-1.0, 1.0, 1.0])
    # root position x -> -x; heading (cos, sin) -> (cos, -sin)
    sign[POS_SLICE] = reflect
    sign[HEADING_SLICE.start + 1] = -1.0
    # 6D of S R S: first column -S r0 = (r00, -r10, -r20), second S r1 = (-r01, r11, r21)
    rot_sign = np.array([1.0, -1.0, -1.0, -1.0, 1.0, 1.0])
    for j in range(JOINT_COUNT):
        dst = ROT6D_SLICE.start + 6 * j
        src = ROT6D_SLICE.start + 6 * MIRROR_JOINTS[j]
        index[dst : dst + 6] = np.arange(src, src + 6)
        sign[dst : dst + 6] = rot_sign
    for j in range(1, JOINT_COUNT):  # J holds joints 1..20
        dst = JOINT_POS_SLICE.start + 3 * (j - 1)
        src = JOINT_POS_SLICE.start + 3 * (MIRROR_JOINTS[j] - 1)
        index[dst : dst + 3] = np.arange(src, src + 3)
        sign[dst : dst + 3] = reflect
    for j in range(JOINT_COUNT):
        dst = JOINT_VEL_SLICE.start + 3 * j
        src = JOINT_VEL_SLICE.start + 3 * MIRROR_JOINTS[j]
        index[dst : dst + 3] = np.arange(src, src + 3)
        sign[dst : dst + 3] = reflect
    for k in range(4):
        index[CONTACT_SLICE.start + k] = CONTACT_SLICE.start + MIRROR_CONTACTS[k]
    index.setflags(write=False)
    sign.setflags(write=False)
    return index, sign


def mirror_features(features: np.ndarray) -> np.ndarray:
    """Left/right mirror of features [..., 258] (exact; mirroring twice gives the input)."""
    index, sign = mirror_permutation_and_signs()
    f = np.asarray(features)
    return (f[..., index] * sign.astype(f.dtype)).astype(f.dtype)


def mirror_labels(content: str, style: str) -> tuple[str, str]:
    """Labels of the mirrored motion."""
    return mirror_content(content), mirror_style(style)


def mirror_clip(clip: Clip) -> Clip:
    """A mirrored copy of a clip, labels swapped, name suffixed with ``_mirror``."""
    content, style = mirror_labels(clip.content, clip.style)
    name = (
        clip.name[: -len(MIRROR_SUFFIX)]
        if clip.name.endswith(MIRROR_SUFFIX)
        else clip.name + MIRROR_SUFFIX
    )
    return replace(
        clip, name=name, content=content, style=style, features=mirror_features(clip.features)
    )


def rotate_yaw(features: np.ndarray, angle: float, pivot_frame: int | None = None) -> np.ndarray:
    """Rotate features [T, 258] about +Y by ``angle`` (radians), about the world origin or
    about the vertical line through the root of ``pivot_frame``."""
    f = np.asarray(features)
    dtype = f.dtype
    x = f.astype(np.float64, copy=True)
    frames = x.shape[0]
    yaw = yaw_matrix(angle)
    pivot = np.zeros(3)
    if pivot_frame is not None:
        pivot = x[pivot_frame, POS_SLICE] * np.array([1.0, 0.0, 1.0])
    x[:, POS_SLICE] = (x[:, POS_SLICE] - pivot) @ yaw.T + pivot
    c, s = np.cos(angle), np.sin(angle)
    cos_psi = x[:, HEADING_SLICE.start].copy()
    sin_psi = x[:, HEADING_SLICE.start + 1].copy()
    x[:, HEADING_SLICE.start] = c * cos_psi - s * sin_psi
    x[:, HEADING_SLICE.start + 1] = s * cos_psi + c * sin_psi
    rot = x[:, ROT6D_SLICE].reshape(frames, JOINT_COUNT, 2, 3)  # two columns per joint
    x[:, ROT6D_SLICE] = (rot @ yaw.T).reshape(frames, -1)
    for part in (JOINT_POS_SLICE, JOINT_VEL_SLICE):
        vectors = x[:, part].reshape(frames, -1, 3)
        x[:, part] = (vectors @ yaw.T).reshape(frames, -1)
    return x.astype(dtype)


def random_yaw(
    features: np.ndarray, rng: np.random.Generator, pivot_frame: int | None = None
) -> tuple[np.ndarray, float]:
    """Rotate by a uniform random yaw in [-pi, pi); returns (features, angle)."""
    angle = float(rng.uniform(-np.pi, np.pi))
    return rotate_yaw(features, angle, pivot_frame), angle
