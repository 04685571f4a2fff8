"""Foot contacts and the foot-skate figure.

Contact labels (the features' last 4 dims): a foot joint (Foot_L, Toes_L, Foot_R, Toes_R) is
in contact when its height is below a height threshold AND its speed (3D, m/s) is below a
speed threshold; both per joint, from configs/data.yaml (``contacts``).

Foot skate, two flavours (both: mean horizontal speed, m/s, of the foot joints over the
frames where they count as in contact, pooled over joints and frames):

* ``foot_skate``: contact by a height threshold only (ARDY's evaluation metric, usable on
  generated motion whatever its contact channel says; thresholds ``skate.height``);
* ``foot_skate_from_contacts``: contact from the features' own contact channel (Kimodo's
  metric, which uses the model's predicted contacts).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ardy_export.data.config import ContactThresholds, load_data_config
from ardy_export.data.features import (
    CONTACT_SLICE,
    FEATURE_SIZE,
    JOINT_VEL_SLICE,
    joint_velocities,
    positions_from_features,
)
from ardy_export.data.skeleton import FOOT_JOINTS, JOINT_COUNT


def compute_contacts(
    positions: np.ndarray,
    velocities: np.ndarray | None = None,
    fps: float | None = None,
    thresholds: ContactThresholds | None = None,
) -> np.ndarray:
    """Contact labels [T, 4] (0.0 / 1.0) from positions [T, 21, 3] and velocities [T, 21, 3]
    (or ``fps`` to compute them)."""
    if thresholds is None:
        thresholds = load_data_config().contacts
    positions = np.asarray(positions, dtype=np.float64)
    if velocities is None:
        if fps is None:
            raise ValueError("compute_contacts needs velocities or fps")
        velocities = joint_velocities(positions, fps)
    feet = list(FOOT_JOINTS)
    height = positions[:, feet, 1]
    speed = np.linalg.norm(np.asarray(velocities)[:, feet], axis=-1)
    low = height < np.asarray(thresholds.height)
    slow = speed < np.asarray(thresholds.speed)
    return (low & slow).astype(np.float64)


def _stack(features: np.ndarray | Iterable[np.ndarray]) -> np.ndarray:
    if isinstance(features, np.ndarray):
        return features.reshape(-1, FEATURE_SIZE)
    parts = [np.asarray(f).reshape(-1, FEATURE_SIZE) for f in features]
    if not parts:
        return np.zeros((0, FEATURE_SIZE))
    return np.concatenate(parts, axis=0)


def _foot_horizontal_speed(f: np.ndarray) -> np.ndarray:
    velocities = f[:, JOINT_VEL_SLICE].reshape(-1, JOINT_COUNT, 3)[:, list(FOOT_JOINTS)]
    return np.hypot(velocities[..., 0], velocities[..., 2]).astype(np.float64)


def foot_skate(
    features: np.ndarray | Iterable[np.ndarray],
    height_thresholds: tuple[float, ...] | np.ndarray | None = None,
) -> float:
    """Mean horizontal foot speed (m/s) while a foot joint is below its height threshold.

    ``features`` is [..., T, 258] or an iterable of [T, 258] arrays (pooled). Heights come
    from the J slice, speeds from the J-dot slice. Returns NaN when no joint is ever low.
    """
    if height_thresholds is None:
        height_thresholds = load_data_config().skate_height
    f = _stack(features)
    heights = positions_from_features(f)[:, list(FOOT_JOINTS), 1]
    in_contact = heights < np.asarray(height_thresholds, dtype=np.float64)
    if not in_contact.any():
        return float("nan")
    return float(_foot_horizontal_speed(f)[in_contact].mean())


def foot_skate_from_contacts(features: np.ndarray | Iterable[np.ndarray]) -> float:
    """Mean horizontal foot speed (m/s) over the frames the contact channel marks (> 0.5)."""
    f = _stack(features)
    in_contact = f[:, CONTACT_SLICE] > 0.5
    if not in_contact.any():
        return float("nan")
    return float(_foot_horizontal_speed(f)[in_contact].mean())


def contact_ratio(features: np.ndarray | Iterable[np.ndarray]) -> np.ndarray:
    """Fraction of frames in contact per foot joint [4]."""
    f = _stack(features)
    return (f[:, CONTACT_SLICE] > 0.5).mean(axis=0)
