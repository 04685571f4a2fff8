"""The model skeleton (design.md section 4), forward kinematics and the BVH -> model conversion.

Model skeleton: 21 joints (``JOINT_NAMES``), Hips is the root, metres, Y up, the character
faces +Z (its left is +X).

Rest pose and rotation frames. The Bandai Namco BVH rig has per-joint local axes (bones
along local +X on the left side and -X on the right side, the spine's lateral axis is local Z,
the hips' is local Y, ...), so its zero pose is not upright and not symmetric. The model
does not use those frames: every joint's rotation is expressed relative to an upright,
mirror-symmetric T-pose facing +Z (arms along +-X, legs down, feet pointing +Z). In numbers,
``R_model = R_bvh @ BVH_REST_FRAMES[j].T`` for the global rotations and
``offset_model = BVH_REST_FRAMES[parent] @ offset_bvh`` for the bone vectors, which keeps
``p_child = p_parent + R_parent @ offset_child`` exact. Consequences:

* All-zero (identity) rotations give the T-pose; the rest offsets in ``Skeleton.offsets``
  describe it. Retargeting can transfer global rotations relative to this rest pose.
* Mirroring across the YZ plane is exactly ``R -> S R S`` with ``S = diag(-1, 1, 1)`` on
  the swapped joint (augment.py), because the rest pose is itself symmetric.

The rest frames are signed permutations read off the rig (each verified in the tests: they
map every left bone to the mirror image of its right bone and agree with the data's mean
heading-aligned pose).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ardy_export.data.bvh import Bvh, bvh_local_transforms
from ardy_export.data.rotations import matrix_to_quaternion, quaternion_slerp, quaternion_to_matrix

JOINT_NAMES: tuple[str, ...] = (
    "Hips", "Spine", "Chest", "Neck", "Head",
    "Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L",
    "Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R",
    "UpperLeg_L", "LowerLeg_L", "Foot_L", "Toes_L",
    "UpperLeg_R", "LowerLeg_R", "Foot_R", "Toes_R",
)  # fmt: skip
JOINT_COUNT = len(JOINT_NAMES)
JOINT_INDEX: dict[str, int] = {name: i for i, name in enumerate(JOINT_NAMES)}
PARENTS: tuple[int, ...] = (
    -1, 0, 1, 2, 3,
    2, 5, 6, 7,
    2, 9, 10, 11,
    0, 13, 14, 15,
    0, 17, 18, 19,
)  # fmt: skip
ROOT_JOINT = 0
FOOT_JOINT_NAMES: tuple[str, ...] = ("Foot_L", "Toes_L", "Foot_R", "Toes_R")
FOOT_JOINTS: tuple[int, ...] = tuple(JOINT_INDEX[name] for name in FOOT_JOINT_NAMES)


def _mirror_name(name: str) -> str:
    if name.endswith("_L"):
        return name[:-2] + "_R"
    if name.endswith("_R"):
        return name[:-2] + "_L"
    return name


# MIRROR_JOINTS[j] is the joint that j becomes under a left/right mirror.
MIRROR_JOINTS: tuple[int, ...] = tuple(JOINT_INDEX[_mirror_name(n)] for n in JOINT_NAMES)
# Contacts (Foot_L, Toes_L, Foot_R, Toes_R) under a mirror.
MIRROR_CONTACTS: tuple[int, ...] = (2, 3, 0, 1)
MIRROR_REFLECTION = np.diag([-1.0, 1.0, 1.0])  # S: reflection across the YZ plane (x -> -x)

BVH_ROOT_NAME = "joint_Root"  # the Bandai rig's ground node, folded into Hips
BVH_UNITS_TO_METRES = 0.01


def _frame(x: tuple[int, int, int], y: tuple[int, int, int]) -> np.ndarray:
    """A rest frame from the world directions of the BVH joint's local X and Y axes."""
    cx = np.array(x, dtype=np.float64)
    cy = np.array(y, dtype=np.float64)
    return np.stack([cx, cy, np.cross(cx, cy)], axis=-1)


_UP, _DOWN = (0, 1, 0), (0, -1, 0)
_LEFT, _RIGHT = (1, 0, 0), (-1, 0, 0)
_FRONT, _BACK = (0, 0, 1), (0, 0, -1)
_HIPS = _frame(_UP, _RIGHT)
_SPINE = _frame(_UP, _FRONT)
_ARM_L = _frame(_LEFT, _UP)
_ARM_R = _frame(_LEFT, _DOWN)
_LEG_L = _frame(_DOWN, _LEFT)
_LEG_R = _frame(_UP, _LEFT)
_FOOT_L = _frame(_FRONT, _LEFT)
_FOOT_R = _frame(_BACK, _LEFT)
# BVH_REST_FRAMES[j]: world orientation of BVH joint j's local axes in the model's T-pose.
BVH_REST_FRAMES: np.ndarray = np.stack(
    [_HIPS]
    + [_SPINE] * 4
    + [_ARM_L] * 4
    + [_ARM_R] * 4
    + [_LEG_L] * 2
    + [_FOOT_L] * 2
    + [_LEG_R] * 2
    + [_FOOT_R] * 2
)

# Bone vectors of the Bandai Namco rig (BVH OFFSETs of joints 1..20, centimetres, in the
# parent's BVH frame), identical in all 3,076 clips except LowerLeg_R's z (0.04 cm apart).
BANDAI_BVH_OFFSETS_CM: np.ndarray = np.array(
    [
        [15.7357, 0.0, 0.0],
        [8.98455, -0.406207, 0.0],
        [16.3773, 0.0, 0.0],
        [6.45672, 0.0, 0.0],
        [12.9942, -0.242716, 4.98039],
        [5.34809, 0.0, 0.0],
        [24.3286, 0.0, 0.0],
        [22.2916, 0.0, 0.0],
        [12.9945, -0.242716, -4.98039],
        [-5.34813, 0.0, 0.0],
        [-24.3289, 0.0, 0.0],
        [-22.2915, 0.0, 0.0],
        [-2.19248, -6.46944, 0.0],
        [39.0811, 0.0, 0.0],
        [40.9854, 0.0, 0.0],
        [11.7543, 0.0, 0.0],
        [-2.19251, 6.46944, 0.0],
        [-39.0811, 0.0, 0.0],
        [-40.9854, 0.0, 0.0],
        [-11.7543, 0.0, 0.0],
    ]
)


@dataclass(frozen=True)
class Skeleton:
    """Joint names, parents and rest offsets (metres, model frame; row 0 is zero)."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray  # [J, 3]

    @property
    def joint_count(self) -> int:
        return len(self.names)

    def rest_positions(self) -> np.ndarray:
        """Joint positions [J, 3] of the rest pose with the root at the origin."""
        identity = np.broadcast_to(np.eye(3), (1, self.joint_count, 3, 3))
        _, positions = fk(identity, np.zeros((1, 3)), self.offsets, self.parents)
        return positions[0]

    def to_dict(self) -> dict[str, object]:
        """JSON-able description (the model package's ``skeleton`` entry)."""
        return {
            "joint_names": list(self.names),
            "parents": list(self.parents),
            "rest_offsets": np.round(self.offsets, 6).tolist(),
            "foot_joints": [self.names[j] for j in FOOT_JOINTS],
            "units": "metres",
            "up": "+Y",
            "forward": "+Z",
            "rest_pose": "T-pose: identity global rotations",
        }


def model_offsets_from_bvh(bvh_offsets: np.ndarray) -> np.ndarray:
    """Model-frame rest offsets [..., J, 3] from BVH bone vectors [..., J, 3] (same units)."""
    out = np.zeros_like(np.asarray(bvh_offsets, dtype=np.float64))
    for j in range(1, JOINT_COUNT):
        out[..., j, :] = bvh_offsets[..., j, :] @ BVH_REST_FRAMES[PARENTS[j]].T
    return out


def default_skeleton() -> Skeleton:
    """The model skeleton of the Bandai Namco rig: rest offsets in metres, made exactly
    mirror-symmetric (the rig's own left/right difference is below 0.5 mm)."""
    bvh = np.zeros((JOINT_COUNT, 3))
    bvh[1:] = BANDAI_BVH_OFFSETS_CM * BVH_UNITS_TO_METRES
    offsets = model_offsets_from_bvh(bvh)
    mirrored = offsets[list(MIRROR_JOINTS)] @ MIRROR_REFLECTION
    return Skeleton(JOINT_NAMES, PARENTS, 0.5 * (offsets + mirrored))


def fk(
    local_rotations: np.ndarray,
    root_positions: np.ndarray,
    offsets: np.ndarray,
    parents: tuple[int, ...] | np.ndarray = PARENTS,
) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics.

    local_rotations [T, J, 3, 3] (each joint relative to its parent; the root's is global),
    root_positions [T, 3], offsets [J, 3] or [T, J, 3] (bone vectors in the parent's frame;
    the root's row is ignored). Parents must precede children. Returns global rotations
    [T, J, 3, 3] and positions [T, J, 3].
    """
    local_rotations = np.asarray(local_rotations, dtype=np.float64)
    offsets = np.asarray(offsets, dtype=np.float64)
    frames, count = local_rotations.shape[:2]
    global_rotations = np.empty_like(local_rotations)
    positions = np.empty((frames, count, 3))
    for j in range(count):
        parent = int(parents[j])
        if parent < 0:
            global_rotations[:, j] = local_rotations[:, j]
            positions[:, j] = root_positions
        else:
            if parent >= j:
                raise ValueError(f"fk: joint {j}'s parent {parent} does not precede it")
            global_rotations[:, j] = global_rotations[:, parent] @ local_rotations[:, j]
            offset = offsets[..., j, :]
            positions[:, j] = positions[:, parent] + np.einsum(
                "tab,...b->ta", global_rotations[:, parent], offset
            )
    return global_rotations, positions


def local_from_global_rotations(
    global_rotations: np.ndarray, parents: tuple[int, ...] | np.ndarray = PARENTS
) -> np.ndarray:
    """Local rotations [..., J, 3, 3] (parent^T @ child) from global ones [..., J, 3, 3]."""
    g = np.asarray(global_rotations, dtype=np.float64)
    local = g.copy()
    for j, parent in enumerate(parents):
        if parent >= 0:
            local[..., j, :, :] = np.swapaxes(g[..., parent, :, :], -1, -2) @ g[..., j, :, :]
    return local


@dataclass
class Motion:
    """A motion on the model skeleton: local rotations (model frames), root path, bone vectors."""

    local_rotations: np.ndarray  # [T, J, 3, 3]
    root_positions: np.ndarray  # [T, 3] metres
    offsets: np.ndarray  # [J, 3] metres, model frame
    fps: float

    @property
    def frame_count(self) -> int:
        return int(self.local_rotations.shape[0])

    def global_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Global rotations [T, J, 3, 3] and positions [T, J, 3]."""
        return fk(self.local_rotations, self.root_positions, self.offsets)


def motion_from_bvh(bvh: Bvh) -> Motion:
    """Convert a parsed Bandai Namco BVH to the model skeleton (same frame rate).

    joint_Root, if present, is folded into Hips (its transform composed into the Hips
    transform); centimetres become metres; rotations are re-expressed in the model's rest
    frames (module docstring). Each clip keeps its own bone vectors.
    """
    local_rotations, local_translations = bvh_local_transforms(bvh)
    names = bvh.names
    missing = [name for name in JOINT_NAMES if name not in names]
    if missing:
        raise ValueError(f"{bvh.source}: the BVH lacks joints {missing}")
    index = [names.index(name) for name in JOINT_NAMES]
    bvh_parents = bvh.parents
    for model_j, bvh_j in enumerate(index):
        parent = PARENTS[model_j]
        expected = index[parent] if parent >= 0 else -1
        actual = int(bvh_parents[bvh_j])
        root_ok = actual == -1 or names[actual] == BVH_ROOT_NAME
        ok = root_ok if parent < 0 else actual == expected
        if not ok:
            raise ValueError(
                f"{bvh.source}: joint {JOINT_NAMES[model_j]} has parent "
                f"{names[actual] if actual >= 0 else None}, expected "
                f"{JOINT_NAMES[parent] if parent >= 0 else BVH_ROOT_NAME}"
            )
    hips = index[0]
    hips_rotation = local_rotations[:, hips]
    hips_position = local_translations[:, hips]
    root_parent = int(bvh_parents[hips])
    if root_parent >= 0:  # fold the ground node (and anything above it) into Hips
        chain: list[int] = []
        k = root_parent
        while k >= 0:
            chain.append(k)
            k = int(bvh_parents[k])
        for k in chain:  # innermost first
            hips_position = local_translations[:, k] + np.einsum(
                "tab,tb->ta", local_rotations[:, k], hips_position
            )
            hips_rotation = local_rotations[:, k] @ hips_rotation
    bvh_local = local_rotations[:, index].copy()
    bvh_local[:, 0] = hips_rotation
    # Model local rotation: Q_parent @ L_bvh @ Q_j^T (so that global = R_bvh @ Q_j^T).
    q = BVH_REST_FRAMES
    parent_q = np.stack([q[p] if p >= 0 else np.eye(3) for p in PARENTS])
    model_local = parent_q[None] @ bvh_local @ np.swapaxes(q, -1, -2)[None]
    bone_vectors = local_translations[0, index] * BVH_UNITS_TO_METRES
    offsets = model_offsets_from_bvh(bone_vectors)
    offsets[0] = 0.0
    return Motion(
        local_rotations=model_local,
        root_positions=hips_position * BVH_UNITS_TO_METRES,
        offsets=offsets,
        fps=bvh.fps,
    )


def resample_motion(motion: Motion, fps: float) -> Motion:
    """Resample to ``fps``: root positions linearly, local rotations by quaternion slerp.

    Output frame k sits at time k / fps; the last output frame is the last one at or before
    the clip's end. Joint positions follow by FK, so bone lengths stay exact.
    """
    if motion.frame_count == 0:
        raise ValueError("resample_motion: empty motion")
    duration = (motion.frame_count - 1) / motion.fps
    count = int(np.floor(duration * fps + 1e-6)) + 1
    source_time = np.arange(count) * (motion.fps / fps)
    lower = np.clip(np.floor(source_time + 1e-9).astype(np.int64), 0, motion.frame_count - 1)
    upper = np.minimum(lower + 1, motion.frame_count - 1)
    t = np.clip(source_time - lower, 0.0, 1.0)
    t = np.where(t < 1e-9, 0.0, t)
    weight = t[:, None]
    root = (1.0 - weight) * motion.root_positions[lower] + weight * motion.root_positions[upper]
    quats = matrix_to_quaternion(motion.local_rotations)
    blended = quaternion_slerp(quats[lower], quats[upper], weight)
    rotations = quaternion_to_matrix(blended)
    exact = t == 0.0
    rotations[exact] = motion.local_rotations[lower[exact]]
    return Motion(rotations, root, motion.offsets.copy(), float(fps))
