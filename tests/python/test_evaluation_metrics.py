"""Evaluation metrics on synthetic data with known answers (and the dataset, when present)."""

from __future__ import annotations

import numpy as np
import pytest

from ardy_export.data import contacts
from ardy_export.data.config import load_data_config
from ardy_export.data.features import joint_velocities, pack_features, positions_from_features
from ardy_export.data.skeleton import FOOT_JOINTS, JOINT_COUNT
from ardy_export.evaluation import metrics
from conftest import processed_dir

FPS = 20.0


def sliding_foot(frames: int = 40) -> np.ndarray:
    """All joints high except Foot_L, which is on the ground (2 cm) and slides at 0.5 m/s
    for the first half, then lifts to 0.3 m and moves at 2 m/s."""
    p = np.zeros((frames, JOINT_COUNT, 3))
    p[..., 1] = 1.0
    foot = FOOT_JOINTS[0]
    low = np.arange(frames) < frames // 2
    speed = np.where(low, 0.5, 2.0)
    p[:, foot, 0] = np.cumsum(speed) / FPS
    p[:, foot, 1] = np.where(low, 0.02, 0.3)
    return p


def test_foot_skate_of_a_sliding_foot() -> None:
    assert metrics.foot_skate(sliding_foot(), FOOT_JOINTS, FPS) == pytest.approx(0.5)
    # pooled over clips, a single threshold for all joints
    both = [sliding_foot(30), sliding_foot(50)]
    assert metrics.foot_skate(both, FOOT_JOINTS, FPS, height_threshold=0.1) == pytest.approx(0.5)
    assert np.isnan(metrics.foot_skate(sliding_foot(), FOOT_JOINTS, FPS, height_threshold=0.01))


def _features(positions: np.ndarray) -> np.ndarray:
    frames = positions.shape[0]
    rotations = np.broadcast_to(np.eye(3), (frames, JOINT_COUNT, 3, 3))
    velocities = joint_velocities(positions, FPS)
    return pack_features(rotations, positions, velocities, np.zeros((frames, 4)), np.float64)


def test_foot_skate_matches_the_feature_based_figure() -> None:
    rng = np.random.default_rng(3)
    clips = []
    for frames in (25, 60):
        p = np.cumsum(rng.normal(0.0, 0.02, (frames, JOINT_COUNT, 3)), axis=0)
        p[..., 1] = np.abs(p[..., 1]) + rng.uniform(0.0, 0.2, (frames, JOINT_COUNT))
        clips.append(p)
    expected = contacts.foot_skate([_features(p) for p in clips])
    assert np.isfinite(expected)
    assert metrics.foot_skate(clips, FOOT_JOINTS, FPS) == pytest.approx(expected, rel=1e-9)


@pytest.mark.requires_prepared_data
def test_foot_skate_matches_the_dataset_figure() -> None:
    from ardy_export.data.dataset import load_clips

    features = [c.features for c in load_clips(processed_dir())]
    expected = contacts.foot_skate(features)
    fps = load_data_config().fps
    positions = [positions_from_features(f) for f in features]
    assert metrics.foot_skate(positions, FOOT_JOINTS, fps) == pytest.approx(expected, rel=1e-3)
    assert expected == pytest.approx(0.086, abs=0.001)  # configs/data.yaml's figure


def test_jerk_of_a_cubic_is_six_times_its_coefficient() -> None:
    t = np.arange(30)[:, None, None] / FPS
    a = np.array([0.3, -0.4, 1.2])
    positions = a * t**3 + 0.5 * t**2 - t + np.ones((1, JOINT_COUNT, 3))
    per_frame = metrics.jerk(positions, FPS)
    assert per_frame.shape == (27,)
    np.testing.assert_allclose(per_frame, 6.0 * np.linalg.norm(a), rtol=1e-6)
    assert metrics.mean_jerk([positions, positions[:10]], FPS) == pytest.approx(
        6.0 * np.linalg.norm(a), rel=1e-6
    )
    assert metrics.mean_jerk(2.0 * t - 1.0 + np.zeros((1, JOINT_COUNT, 3)), FPS) < 1e-6


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def test_r_precision_identical_and_shuffled() -> None:
    rng = np.random.default_rng(0)
    emb = _unit(rng.normal(size=(600, 32)))
    assert metrics.r_precision(emb, emb, top_k=3, pool=32) == 1.0
    shuffled = emb[rng.permutation(len(emb))]
    chance = metrics.r_precision_chance(3, 32)
    assert chance == pytest.approx(3 / 32)
    assert metrics.r_precision(emb, shuffled, top_k=3, pool=32) == pytest.approx(chance, abs=0.04)


def test_r_precision_with_labels_draws_distinct_labels() -> None:
    rng = np.random.default_rng(1)
    labels = rng.integers(0, 40, 800)
    label_emb = _unit(rng.normal(size=(40, 64)))
    text = label_emb[labels]
    motion = _unit(text + rng.normal(0.0, 0.01, text.shape))
    # texts of the same label are never in the pool, so equal label texts cannot tie
    assert metrics.r_precision(motion, text, top_k=1, pool=32, label_ids=labels) == 1.0
    noise = _unit(rng.normal(size=text.shape))
    r = metrics.r_precision(noise, text, top_k=3, pool=32, label_ids=labels)
    assert r == pytest.approx(3 / 32, abs=0.04)
    with pytest.raises(ValueError, match="labels"):
        metrics.r_precision(motion, text, pool=41, label_ids=labels)


def test_fid() -> None:
    rng = np.random.default_rng(2)
    real = rng.normal(size=(2000, 8)) @ rng.normal(size=(8, 8))
    assert metrics.fid(real, real) == pytest.approx(0.0, abs=1e-6)
    shift = np.array([1.0, -2.0, 0.0, 0.5, 0.0, 0.0, 0.0, 3.0])
    assert metrics.fid(real, real + shift) == pytest.approx(float(shift @ shift), rel=1e-5)
    # independent samples of N(0, I) and N(0, 4 I): trace term 8 * (1 - 2)^2 = 8
    wide = rng.normal(size=(20000, 8))
    assert metrics.fid(wide, 2.0 * rng.normal(size=(20000, 8))) == pytest.approx(8.0, rel=0.05)


def test_multimodal_distance() -> None:
    a = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert metrics.multimodal_distance(a, a) == 0.0
    assert metrics.multimodal_distance(a, -a) == pytest.approx(2.0)


def test_seam_jerk_finds_a_jump_at_every_patch_seam() -> None:
    # A smooth line plus a 1 cm step at every 4th frame (frame 0 starts a patch): the third
    # differences centred on a seam see the steps, those inside a patch do not.
    frames = 40
    p = np.zeros((frames, JOINT_COUNT, 3))
    p[..., 0] = (np.arange(frames) * 0.05)[:, None]
    p[..., 1] = 1.0
    p[..., 2] = (0.01 * (np.arange(frames) // 4))[:, None]
    seams = metrics.seam_jerk(p, FPS, 4)
    assert seams["inside_patches"] == pytest.approx(0.0, abs=1e-9)
    assert seams["across_seams"] == pytest.approx(0.01 * 2 * FPS**3)  # h - 3h + 0 - 0
    # Shifted by two frames the seams fall inside the "inside" entries instead.
    shifted = metrics.seam_jerk(p[2:], FPS, 4)
    assert shifted["across_seams"] == pytest.approx(0.0, abs=1e-9)
    assert shifted["inside_patches"] > 0
    smooth = p.copy()
    smooth[..., 2] = (np.arange(frames) ** 3 * 1e-4)[:, None]
    assert metrics.seam_jerk([smooth], FPS, 4)["ratio"] == pytest.approx(1.0)


def test_contact_agreement_against_the_data_rule() -> None:
    p = sliding_foot()
    rule = contacts.compute_contacts(p, fps=FPS)
    assert metrics.contact_agreement(p, rule, FPS) == pytest.approx(1.0)
    # Flags that claim "no contact" everywhere agree exactly where the rule says no contact.
    none = np.zeros_like(rule)
    assert metrics.contact_agreement([p], [none], FPS) == pytest.approx(1.0 - rule.mean())
    flipped = 1.0 - rule
    assert metrics.contact_agreement(p, flipped, FPS) == pytest.approx(0.0)
    with pytest.raises(ValueError, match="one contact array per clip"):
        metrics.contact_agreement([p, p], [rule], FPS)


def test_balanced_indices_draw_the_same_number_of_every_label() -> None:
    labels = np.array([0] * 50 + [1] + [2] * 3)
    picks = metrics.balanced_indices(labels, 8, seed=0)
    assert len(picks) == 24
    assert np.bincount(labels[picks]).tolist() == [8, 8, 8]
    assert np.array_equal(picks, metrics.balanced_indices(labels, 8, seed=0))  # fixed seed
