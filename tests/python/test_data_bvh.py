"""BVH reading, the model skeleton, forward kinematics and resampling."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ardy_export.data.bvh import BvhError, bvh_local_transforms, parse_bvh, read_bvh, write_bvh
from ardy_export.data.features import JOINT_POS_SLICE, positions_from_features
from ardy_export.data.rotations import (
    euler_to_matrix,
    matrix_from_rot6d,
    matrix_to_euler,
    matrix_to_quaternion,
    quaternion_slerp,
    quaternion_to_matrix,
    rot6d_from_matrix,
    rotation_angle,
    yaw_matrix,
)
from ardy_export.data.skeleton import (
    BVH_REST_FRAMES,
    JOINT_NAMES,
    MIRROR_JOINTS,
    MIRROR_REFLECTION,
    PARENTS,
    default_skeleton,
    fk,
    local_from_global_rotations,
    motion_from_bvh,
    resample_motion,
)
from test_data_common import CLIP_NAMES, all_clip_paths, clip_path, naive_bvh_positions

SMALL_BVH = """HIERARCHY
ROOT hip
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT knee
  {
    OFFSET 0 -10 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 -5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 2 3 90 0 0 0 0 0
0 0 0 0 0 0 90 0 0
"""


def test_parse_small_file_and_euler_order() -> None:
    bvh = parse_bvh(SMALL_BVH)
    assert bvh.names == ["hip", "knee"]
    assert list(bvh.parents) == [-1, 0]
    assert bvh.fps == 30.0
    assert bvh.joints[1].end_site is not None
    rotations, translations = bvh_local_transforms(bvh)
    np.testing.assert_allclose(translations[0, 0], [1, 2, 3])
    np.testing.assert_allclose(translations[:, 1], [[0, -10, 0]] * 2)  # OFFSET without channels
    # frame 0: hip Zrotation 90 -> x axis to y axis
    np.testing.assert_allclose(rotations[0, 0] @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    # frame 1: knee Xrotation 90 (order XYZ) -> y axis to z axis
    np.testing.assert_allclose(rotations[1, 1] @ [0, 1, 0], [0, 0, 1], atol=1e-12)


def test_channel_order_is_the_multiplication_order() -> None:
    angles = np.radians([30.0, 40.0, 50.0])
    expected = (
        euler_to_matrix(angles[None, :1] * [[1, 0, 0]], "ZXY")
        @ euler_to_matrix(np.array([[0, angles[1], 0]]), "ZXY")
        @ euler_to_matrix(np.array([[0, 0, angles[2]]]), "ZXY")
    )
    np.testing.assert_allclose(euler_to_matrix(angles[None], "ZXY"), expected, atol=1e-12)
    rng = np.random.default_rng(0)
    for order in ("XYZ", "ZXY", "YXZ", "ZYX", "XZY", "YZX"):
        a = rng.uniform(-3.0, 3.0, size=(200, 3))
        a[:, 1] = rng.uniform(-1.5, 1.5, size=200)
        a[:3, 1] = np.pi / 2  # gimbal lock
        matrices = euler_to_matrix(a, order)
        np.testing.assert_allclose(
            euler_to_matrix(matrix_to_euler(matrices, order), order), matrices, atol=1e-9
        )


@pytest.mark.parametrize(
    "text",
    [
        SMALL_BVH.replace("MOTION", "MOTON"),
        SMALL_BVH.replace("0 0 0 0 0 0 90 0 0", "0 0 0 0 0 0 90 0"),
        SMALL_BVH.replace("CHANNELS 3 Xrotation", "CHANNELS 3 Wrotation"),
        SMALL_BVH.replace("1 2 3 90", "1 2 nan 90"),
    ],
)
def test_bad_files_raise_a_clear_error(text: str) -> None:
    with pytest.raises(BvhError, match=r"test\.bvh"):
        parse_bvh(text, source="test.bvh")


def test_rotation_helpers() -> None:
    rng = np.random.default_rng(1)
    q = rng.normal(size=(100, 4))
    r = quaternion_to_matrix(q)
    np.testing.assert_allclose(
        r @ np.swapaxes(r, -1, -2), np.broadcast_to(np.eye(3), r.shape), atol=1e-12
    )
    np.testing.assert_allclose(quaternion_to_matrix(matrix_to_quaternion(r)), r, atol=1e-12)
    np.testing.assert_allclose(matrix_from_rot6d(rot6d_from_matrix(r)), r, atol=1e-12)
    six = rot6d_from_matrix(r[0])
    np.testing.assert_allclose(
        six, [r[0][0, 0], r[0][1, 0], r[0][2, 0], r[0][0, 1], r[0][1, 1], r[0][2, 1]]
    )
    half = quaternion_to_matrix(
        quaternion_slerp(
            matrix_to_quaternion(np.eye(3)), matrix_to_quaternion(yaw_matrix(1.0)), 0.5
        )
    )
    np.testing.assert_allclose(half, yaw_matrix(0.5), atol=1e-12)
    np.testing.assert_allclose(yaw_matrix(0.3) @ [0, 0, 1], [np.sin(0.3), 0, np.cos(0.3)])


@pytest.mark.requires_data
def test_fk_of_parsed_clips_matches_the_files_own_positions() -> None:
    """Our pipeline (fold joint_Root, rest frames, metres) against an independent naive FK of
    the raw file at 30 fps: every joint within 1 mm, in every frame."""
    for name in (
        "dataset-1_walk_normal_002",
        "dataset-1_run_normal_001",
        "dataset-2_walk-turn-left_normal_001",
    ):
        path = clip_path(name)
        names, naive = naive_bvh_positions(path)
        expected = naive[:, [names.index(n) for n in JOINT_NAMES]] * 0.01
        motion = motion_from_bvh(read_bvh(path))
        _, positions = motion.global_pose()
        assert positions.shape == expected.shape
        assert np.abs(positions - expected).max() < 1e-3, name
        # The resampled clip (20 fps) hits every third source frame exactly, and the feature
        # vector's joint positions are those positions.
        resampled = resample_motion(motion, 20.0)
        _, positions20 = resampled.global_pose()
        assert resampled.frame_count == (motion.frame_count - 1) * 2 // 3 + 1
        assert np.abs(positions20[::2] - expected[::3]).max() < 1e-3
        from ardy_export.data.features import features_from_motion

        rotations20, _ = resampled.global_pose()
        features = features_from_motion(rotations20, positions20, 20.0)
        assert features[:, JOINT_POS_SLICE].shape == (resampled.frame_count, 60)
        assert np.abs(positions_from_features(features)[::2] - expected[::3]).max() < 1e-3


@pytest.mark.requires_data
def test_joint_root_translation_is_folded_into_hips() -> None:
    bvh = read_bvh(clip_path("dataset-1_walk_normal_002"))
    root = bvh.channels_of("joint_Root")
    assert np.abs(root).max() > 1.0  # this clip does move its ground node
    motion = motion_from_bvh(bvh)
    hips = bvh.channels_of("Hips")[:, :3]
    np.testing.assert_allclose(motion.root_positions, (hips + root[:, :3]) * 0.01, atol=1e-9)


@pytest.mark.requires_data
def test_position_channels_below_hips_equal_offsets() -> None:
    for path in all_clip_paths():
        bvh = read_bvh(path)
        _, translations = bvh_local_transforms(bvh)
        below = [bvh.joint_index(n) for n in JOINT_NAMES[1:]]
        assert np.abs(translations[:, below] - bvh.offsets[below]).max() < 1e-4


@pytest.mark.requires_data
def test_skeleton_definition() -> None:
    assert len(JOINT_NAMES) == 21 and JOINT_NAMES[0] == "Hips" and JOINT_NAMES[20] == "Toes_R"
    for j, parent in enumerate(PARENTS):
        assert parent < j
    for q in BVH_REST_FRAMES:
        np.testing.assert_allclose(q @ q.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(q) == pytest.approx(1.0)
    skeleton = default_skeleton()
    rest = skeleton.rest_positions()
    # Symmetric T-pose facing +Z: left joints at +x, mirror images of the right ones.
    np.testing.assert_allclose(rest[list(MIRROR_JOINTS)] @ MIRROR_REFLECTION, rest, atol=1e-12)
    assert rest[JOINT_NAMES.index("Hand_L"), 0] > 0.5
    assert rest[JOINT_NAMES.index("Head"), 1] > 0.4
    assert rest[JOINT_NAMES.index("Toes_L"), 2] > 0.1
    # The real clips' bone vectors agree with the default skeleton within 1 mm.
    for path in all_clip_paths()[:3]:
        motion = motion_from_bvh(read_bvh(path))
        assert np.abs(motion.offsets - skeleton.offsets).max() < 1e-3


@pytest.mark.requires_data
def test_rest_frames_agree_with_the_data() -> None:
    """Heading-aligned global rotations of walking clips stay near identity for the spine and
    legs (the rest pose is an upright T-pose facing +Z)."""
    from ardy_export.data.features import heading_from_positions

    angles = []
    for name in ("dataset-2_walk_normal_001", "dataset-1_walk_normal_002"):
        rotations, positions = motion_from_bvh(read_bvh(clip_path(name))).global_pose()
        unyaw = yaw_matrix(-heading_from_positions(positions))
        aligned = np.einsum("tab,tjbc->tjac", unyaw, rotations)
        angles.append(np.degrees(rotation_angle(aligned)).mean(axis=0))
    mean = np.mean(angles, axis=0)
    for joint in ("Hips", "Spine", "Chest", "UpperLeg_L", "UpperLeg_R", "Shoulder_L", "Shoulder_R"):
        assert mean[JOINT_NAMES.index(joint)] < 30.0, (joint, mean)


def test_fk_and_local_rotations_round_trip() -> None:
    rng = np.random.default_rng(3)
    local = quaternion_to_matrix(rng.normal(size=(5, 21, 4)))
    root = rng.normal(size=(5, 3))
    offsets = default_skeleton().offsets
    global_rotations, positions = fk(local, root, offsets)
    np.testing.assert_allclose(local_from_global_rotations(global_rotations), local, atol=1e-12)
    # bone lengths are preserved
    lengths = np.linalg.norm(positions[:, 1:] - positions[:, list(PARENTS[1:])], axis=-1)
    np.testing.assert_allclose(
        lengths, np.broadcast_to(np.linalg.norm(offsets[1:], axis=-1), lengths.shape), atol=1e-12
    )


@pytest.mark.requires_data
def test_write_bvh_round_trip(tmp_path: Path) -> None:
    motion = resample_motion(motion_from_bvh(read_bvh(clip_path(CLIP_NAMES["dataset-2"][0]))), 20.0)
    _, positions = motion.global_pose()
    out = tmp_path / "out.bvh"
    write_bvh(
        out,
        list(JOINT_NAMES),
        np.array(PARENTS),
        motion.offsets,
        motion.local_rotations,
        motion.root_positions,
        0.05,
        scale=100.0,
    )
    back = motion_from_bvh_model(out)
    np.testing.assert_allclose(back, positions, atol=1e-4)


@pytest.mark.requires_data
def test_write_features_bvh(tmp_path: Path) -> None:
    from ardy_export.data.features import write_features_bvh
    from test_data_common import real_clips

    clip = real_clips()[2]
    write_features_bvh(tmp_path / "clip.bvh", clip.features)
    positions = motion_from_bvh_model(tmp_path / "clip.bvh")
    assert np.abs(positions - positions_from_features(clip.features)).max() < 2e-3


def motion_from_bvh_model(path: Path) -> np.ndarray:
    """Positions (metres) of a BVH written on the model skeleton (no rest frames)."""
    bvh = read_bvh(path)
    local, translations = bvh_local_transforms(bvh)
    _, positions = fk(local, translations[:, 0] * 0.01, translations[0] * 0.01, bvh.parents)
    return positions
