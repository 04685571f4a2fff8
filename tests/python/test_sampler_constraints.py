"""World-space constraints -> per-window goal tensors (re-centered, normalized, patchified)."""

from __future__ import annotations

import numpy as np
import pytest

from ardy_export.models import layout as L
from ardy_export.sampling.constraints import (
    FootContact,
    JointTarget,
    PoseKeyframe,
    RootPath,
    RootWaypoint,
    path_from_polyline,
    pose_features,
    rasterize,
    split_by_time,
    validate,
    window_goals,
)
from ardy_export.training.synthetic import synthetic_clip

C, P, M = 10, 4, L.FEATURE_SIZE
MEAN = np.linspace(-0.5, 0.5, M).astype(np.float32)
STD = np.linspace(0.5, 2.0, M).astype(np.float32)


def _at(goals: np.ndarray, frame: int, feature: int) -> float:
    """Value of a frame (relative to the window start) and feature in patchified goals."""
    return float(goals[frame // P, (frame % P) * M + feature])


def test_waypoint_inside_the_window_is_recentered_and_normalized() -> None:
    wp = RootWaypoint(frame=107, x=3.0, z=-2.0, heading=0.5)
    g = window_goals([wp], 100, (1.0, 4.0), MEAN, STD, C, 5)
    f = 7
    assert _at(g.window_goal_mask, f, 0) == 1 and _at(g.window_goal_mask, f, 2) == 1
    assert _at(g.window_goal_mask, f, 1) == 0  # height free
    assert np.isclose(_at(g.window_goal, f, 0), (3.0 - 1.0 - MEAN[0]) / STD[0])
    assert np.isclose(_at(g.window_goal, f, 2), (-2.0 - 4.0 - MEAN[2]) / STD[2])
    assert np.isclose(_at(g.window_goal, f, 3), (np.cos(0.5) - MEAN[3]) / STD[3])
    assert np.isclose(_at(g.window_goal, f, 4), (np.sin(0.5) - MEAN[4]) / STD[4])
    assert g.window_goal_mask.sum() == 4
    assert g.future_tokens == 0 and not g.future_mask.any()
    assert np.all(g.window_goal[g.window_goal_mask == 0] == 0)


def test_interpolate_turns_sparse_root_targets_into_a_path_from_the_character() -> None:
    # The same case as test_constraints.cpp's (unit statistics, start 40, anchor (1, 2)).
    zero, one = np.zeros(M, np.float32), np.ones(M, np.float32)
    targets = [
        RootWaypoint(49, 3.0, 4.0, 0.5),
        RootWaypoint(59, 5.0, 4.0),
        FootContact(42, 44, (0,), 1.0),
    ]
    g = window_goals(targets, 40, (1.0, 2.0), zero, one, C, 4, interpolate=True)
    for f in range(10):
        a = (f + 1) / 10
        assert np.isclose(_at(g.window_goal, f, 0), a * 2.0)
        assert np.isclose(_at(g.window_goal, f, 2), a * 2.0)
        assert _at(g.window_goal_mask, f, 1) == 0
    assert _at(g.window_goal_mask, 8, 3) == 0 and _at(g.window_goal_mask, 9, 3) == 1
    assert np.isclose(_at(g.window_goal, 14, 0), 3.0) and np.isclose(_at(g.window_goal, 14, 2), 2.0)
    assert _at(g.window_goal_mask, 20, 0) == 0
    assert g.window_goal_mask.sum() == 20 * 2 + 2 + 2
    sparse = window_goals(targets, 40, (1.0, 2.0), zero, one, C, 4)
    assert sparse.window_goal_mask.sum() == 2 + 2 + 2 + 2


def test_root_targets_are_pulled_back_to_the_speed_limit() -> None:
    # The same case as test_constraints.cpp's: 0.3 m per frame from the anchor (1, 2).
    zero, one = np.zeros(M, np.float32), np.ones(M, np.float32)
    targets = [
        RootWaypoint(49, 11.0, 2.0),  # 10 m in 10 frames: only 3 m reachable
        RootPath(50, [(4.0, 6.0), (4.0, 6.1)]),  # 4 m beside the pulled-back waypoint
    ]
    g = window_goals(targets, 40, (1.0, 2.0), zero, one, C, 4, max_root_step=0.3)
    assert np.isclose(_at(g.window_goal, 9, 0), 3.0) and np.isclose(_at(g.window_goal, 9, 2), 0.0)
    assert np.isclose(_at(g.window_goal, 10, 0), 3.0) and np.isclose(_at(g.window_goal, 10, 2), 0.3)
    assert np.isclose(_at(g.window_goal, 11, 0), 3.0) and np.isclose(_at(g.window_goal, 11, 2), 0.6)
    free = window_goals(targets, 40, (1.0, 2.0), zero, one, C, 4)
    assert np.isclose(_at(free.window_goal, 9, 0), 10.0)


def test_future_goals_are_cut_after_the_last_constrained_token() -> None:
    start = 40
    wp = RootWaypoint(frame=start + C * P + 2 * P + 1, x=1.0, z=1.0)  # future token 2
    g = window_goals([wp], start, (0.0, 0.0), MEAN, STD, C, 6)
    assert g.future_tokens == 3
    assert g.future_mask.tolist() == [0.0, 0.0, 1.0]
    assert not g.window_goal_mask.any()
    assert g.future_goal_mask[2, 1 * M + 0] == 1.0
    assert g.has_constraints


def test_passed_constraints_are_dropped_and_far_ones_wait() -> None:
    start, limit = 80, 4
    horizon = (C + limit) * P
    passed = RootWaypoint(frame=start - 1, x=9.0, z=9.0)
    waiting = RootWaypoint(frame=start + horizon, x=5.0, z=5.0)
    edge = RootWaypoint(frame=start + horizon - 1, x=5.0, z=5.0)
    g = window_goals([passed, waiting], start, (0.0, 0.0), MEAN, STD, C, limit)
    assert not g.has_constraints and g.future_tokens == 0
    g2 = window_goals([passed, waiting, edge], start, (0.0, 0.0), MEAN, STD, C, limit)
    assert g2.future_tokens == limit and g2.future_mask[-1] == 1.0
    p, a, w = split_by_time([passed, waiting, edge], start, horizon)
    assert p == [passed] and a == [edge] and w == [waiting]
    # a later window brings the waiting one in
    g3 = window_goals([waiting], start + C * P, (0.0, 0.0), MEAN, STD, C, limit)
    assert g3.has_constraints


def test_dense_path_spanning_windows() -> None:
    path = path_from_polyline([(0.0, 0.0), (0.0, 10.0)], speed=1.0, start_frame=0)
    assert np.allclose(path.positions[:3, 1], [0.0, 0.05, 0.1])
    assert np.allclose(path.headings, 0.0)
    g = window_goals([path], 40, (0.0, 2.0), MEAN, STD, C, 2)
    mask = g.window_goal_mask.reshape(C * P, M)
    assert mask[:, 0].all() and mask[:, 2].all() and mask[:, 3].all()
    z = g.window_goal.reshape(C * P, M)[:, 2] * STD[2] + MEAN[2]
    assert np.allclose(z, path.positions[40:80, 1] - 2.0, atol=1e-5)
    assert g.future_tokens == 2


def test_keyframe_joint_target_and_contacts() -> None:
    f = synthetic_clip("walk", "normal", 2.0, np.random.default_rng(0))
    key = PoseKeyframe(frame=5, features=f[5].astype(np.float64))
    rot = np.eye(3)
    hand = L.JOINT_NAMES.index("Hand_R")
    jt = JointTarget(frame=6, joint=hand, position=np.array([0.1, 1.2, 0.3]), rotation=rot)
    root_t = JointTarget(frame=7, joint=0, position=np.array([2.0, 0.9, 3.0]))
    contact = FootContact(8, 10, feet=(0, 2), value=1.0)
    goal, mask = rasterize([key, jt, root_t, contact], 0, 12)
    assert mask[5, L.ROOT_SLICE].all() and mask[5, L.ROT6D_SLICE].all()
    assert mask[5, L.JOINT_POS_SLICE].all() and not mask[5, L.JOINT_VEL_SLICE].any()
    assert np.allclose(goal[5, L.JOINT_POS_SLICE], f[5, L.JOINT_POS_SLICE])
    assert np.allclose(goal[6, L.joint_pos_slice(hand)], [0.1, 1.2, 0.3])
    assert np.allclose(goal[6, L.rot6d_slice(hand)], [1, 0, 0, 0, 1, 0])
    assert mask[6].sum() == 9
    assert np.allclose(goal[7, L.POS_SLICE], [2.0, 0.9, 3.0]) and mask[7].sum() == 3
    cs = L.CONTACT_SLICE.start
    assert mask[8:10, [cs, cs + 2]].all() and mask[8:10].sum() == 4
    assert not mask[10:].any()
    # re-centering moves the root x/z but no relative joint target
    g = window_goals([jt, root_t], 0, (1.0, 1.0), np.zeros(M), np.ones(M), C, 0)
    assert np.isclose(_at(g.window_goal, 7, 0), 1.0) and np.isclose(_at(g.window_goal, 7, 1), 0.9)
    assert np.isclose(_at(g.window_goal, 6, L.joint_pos_slice(hand).start), 0.1)


def test_pose_features_and_world_joint_target() -> None:
    f = synthetic_clip("run", "active", 1.0, np.random.default_rng(1))
    from ardy_export.data.features import motion_from_features

    rot, pos = motion_from_features(f[:3])
    feat = pose_features(rot[2], pos[2])
    assert np.allclose(feat[L.ROOT_SLICE], f[2, L.ROOT_SLICE], atol=1e-5)
    assert np.allclose(feat[L.ROT6D_SLICE], f[2, L.ROT6D_SLICE], atol=1e-5)
    assert np.allclose(feat[L.JOINT_POS_SLICE], f[2, L.JOINT_POS_SLICE], atol=1e-5)
    jt = JointTarget.from_world(3, 8, pos[2, 8], (pos[2, 0, 0], pos[2, 0, 2]))
    assert np.allclose(jt.position, f[2, L.joint_pos_slice(8)], atol=1e-5)


def test_later_constraints_override_and_validation() -> None:
    a = RootWaypoint(frame=3, x=1.0, z=1.0)
    b = RootWaypoint(frame=3, x=2.0, z=2.0)
    goal, _ = rasterize([a, b], 0, 8)
    assert goal[3, 0] == 2.0
    with pytest.raises(ValueError, match="NaN"):
        validate(RootWaypoint(frame=0, x=float("nan"), z=0.0))
    with pytest.raises(ValueError, match="joint"):
        validate(JointTarget(frame=0, joint=99, position=np.zeros(3)))
    with pytest.raises(ValueError, match="RootPath"):
        validate(RootPath(0, np.zeros((3, 3))))
