"""The per-frame feature layout and skeleton the models are built around (design.md section 4).

The data package (``ardy_export.data.features`` / ``.skeleton``) owns these facts; this
module re-exports them when that package is importable and otherwise falls back to the same
constants written out from design.md, so the models, losses and the reference sampler can be
developed and tested without the data pipeline. Everything here is plain Python and numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FPS = 20.0
PATCH = 4

_FALLBACK_JOINT_NAMES: tuple[str, ...] = (
    "Hips",
    "Spine",
    "Chest",
    "Neck",
    "Head",
    "Shoulder_L",
    "UpperArm_L",
    "LowerArm_L",
    "Hand_L",
    "Shoulder_R",
    "UpperArm_R",
    "LowerArm_R",
    "Hand_R",
    "UpperLeg_L",
    "LowerLeg_L",
    "Foot_L",
    "Toes_L",
    "UpperLeg_R",
    "LowerLeg_R",
    "Foot_R",
    "Toes_R",
)
_FALLBACK_PARENTS: tuple[int, ...] = (
    -1,
    0,
    1,
    2,
    3,
    2,
    5,
    6,
    7,
    2,
    9,
    10,
    11,
    0,
    13,
    14,
    15,
    0,
    17,
    18,
    19,
)

try:  # pragma: no cover - depends on which parts of the package exist
    from ardy_export.data import features as _features
    from ardy_export.data import skeleton as _skeleton

    JOINT_NAMES: tuple[str, ...] = tuple(_skeleton.JOINT_NAMES)
    PARENTS: tuple[int, ...] = tuple(int(p) for p in _skeleton.PARENTS)
    FEATURE_SIZE: int = int(_features.FEATURE_SIZE)
    HAVE_DATA_PACKAGE = True
except (ImportError, AttributeError):
    JOINT_NAMES = _FALLBACK_JOINT_NAMES
    PARENTS = _FALLBACK_PARENTS
    FEATURE_SIZE = 258
    HAVE_DATA_PACKAGE = False

NUM_JOINTS = len(JOINT_NAMES)
ROOT_DIM = 5
BODY_DIM = FEATURE_SIZE - ROOT_DIM

# Slices of the per-frame feature vector (design.md section 4). Written out from the joint
# count so a package with another skeleton only changes NUM_JOINTS.
ROOT_SLICE = slice(0, 5)
POS_SLICE = slice(0, 3)
HEADING_SLICE = slice(3, 5)
BODY_SLICE = slice(5, FEATURE_SIZE)
ROT6D_SLICE = slice(5, 5 + 6 * NUM_JOINTS)
JOINT_POS_SLICE = slice(ROT6D_SLICE.stop, ROT6D_SLICE.stop + 3 * (NUM_JOINTS - 1))
JOINT_VEL_SLICE = slice(JOINT_POS_SLICE.stop, JOINT_POS_SLICE.stop + 3 * NUM_JOINTS)
CONTACT_SLICE = slice(JOINT_VEL_SLICE.stop, JOINT_VEL_SLICE.stop + 4)
assert CONTACT_SLICE.stop == FEATURE_SIZE, "feature layout does not add up"

FOOT_JOINT_NAMES: tuple[str, ...] = ("Foot_L", "Toes_L", "Foot_R", "Toes_R")
FOOT_JOINTS: tuple[int, ...] = tuple(JOINT_NAMES.index(n) for n in FOOT_JOINT_NAMES)
# End effectors used by the training-time constraint sampler (hands, feet, head).
END_EFFECTORS: tuple[int, ...] = tuple(
    JOINT_NAMES.index(n) for n in ("Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head")
)
LEFT_HIP = JOINT_NAMES.index("UpperLeg_L")
RIGHT_HIP = JOINT_NAMES.index("UpperLeg_R")


def rot6d_slice(joint: int) -> slice:
    """Feature indices of one joint's 6D rotation."""
    start = ROT6D_SLICE.start + 6 * joint
    return slice(start, start + 6)


def joint_pos_slice(joint: int) -> slice:
    """Feature indices of a non-root joint's position (joint >= 1)."""
    if joint < 1:
        raise ValueError("the root joint has no entry in J (use the root position p)")
    start = JOINT_POS_SLICE.start + 3 * (joint - 1)
    return slice(start, start + 3)


def joint_vel_slice(joint: int) -> slice:
    start = JOINT_VEL_SLICE.start + 3 * joint
    return slice(start, start + 3)


@dataclass(frozen=True)
class Skeleton:
    """Joint hierarchy and rest offsets (metres, parent frame) of the model skeleton."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray  # [J, 3] float32; offsets[0] is unused (the root sits at p)

    def __post_init__(self) -> None:
        if len(self.names) != len(self.parents) or self.offsets.shape != (len(self.names), 3):
            raise ValueError(
                f"skeleton: {len(self.names)} names, {len(self.parents)} parents, "
                f"offsets {self.offsets.shape}; expected the same joint count everywhere"
            )
        for j, p in enumerate(self.parents):
            if p >= j:
                raise ValueError(f"skeleton: joint {j} has parent {p}; parents must come first")

    @property
    def num_joints(self) -> int:
        return len(self.names)
