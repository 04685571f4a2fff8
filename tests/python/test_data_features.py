"""The 258 per-frame features, contacts, foot skate, re-centering and normalization."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from ardy_export.data.config import DEFAULT_CONFIG_PATH, DataConfig, load_data_config
from ardy_export.data.contacts import (
    compute_contacts,
    contact_ratio,
    foot_skate,
    foot_skate_from_contacts,
)
from ardy_export.data.features import (
    BODY_SLICE,
    CONTACT_SLICE,
    FEATURE_LAYOUT,
    FEATURE_SIZE,
    HEADING_SLICE,
    JOINT_POS_SLICE,
    JOINT_VEL_SLICE,
    POS_SLICE,
    ROOT_SLICE,
    ROT6D_SLICE,
    features_from_motion,
    heading_from_positions,
    joint_velocities,
    motion_from_features,
    recenter,
    uncenter,
)
from ardy_export.data.normalization import NormalizationStats, compute_normalization_stats
from ardy_export.data.rotations import yaw_matrix
from ardy_export.data.skeleton import FOOT_JOINTS, JOINT_NAMES, default_skeleton, fk
from test_data_common import real_clips


def test_layout_constants() -> None:
    assert FEATURE_SIZE == 258
    slices = (
        POS_SLICE,
        HEADING_SLICE,
        ROOT_SLICE,
        ROT6D_SLICE,
        JOINT_POS_SLICE,
        JOINT_VEL_SLICE,
        CONTACT_SLICE,
        BODY_SLICE,
    )
    spans = [(s.start, s.stop) for s in slices]
    assert spans == [(0, 3), (3, 5), (0, 5), (5, 131), (131, 191), (191, 254), (254, 258), (5, 258)]
    spans = list(FEATURE_LAYOUT.values())
    assert spans[0][0] == 0 and spans[-1][1] == FEATURE_SIZE
    assert all(a[1] == b[0] for a, b in itertools.pairwise(spans))
    assert [JOINT_NAMES[j] for j in FOOT_JOINTS] == ["Foot_L", "Toes_L", "Foot_R", "Toes_R"]


def test_config_file_matches_builtin_defaults() -> None:
    """configs/data.yaml is the record; the dataclass defaults mirror it."""
    from_file = load_data_config(DEFAULT_CONFIG_PATH)
    defaults = DataConfig()
    for name in DataConfig.__dataclass_fields__:
        if name != "raw_dict":
            assert getattr(from_file, name) == getattr(defaults, name), name


def test_heading_definition() -> None:
    rest = default_skeleton().rest_positions()[None]  # T-pose facing +Z
    assert heading_from_positions(rest)[0] == pytest.approx(0.0, abs=1e-12)
    for angle in (0.5, -2.0, 3.0):
        turned = rest @ yaw_matrix(angle).T
        assert heading_from_positions(turned)[0] == pytest.approx(angle, abs=1e-9)


def test_velocity_convention() -> None:
    x = np.array([[0.0], [1.0], [3.0], [6.0]])
    np.testing.assert_allclose(joint_velocities(x, 20.0)[:, 0], [20.0, 20.0, 40.0, 60.0])


@pytest.mark.requires_data
def test_features_round_trip_on_real_clips() -> None:
    """features -> pose -> features within 1e-4."""
    for clip in real_clips():
        rotations, positions = motion_from_features(clip.features)
        again = features_from_motion(rotations, positions, 20.0, clip.features[:, CONTACT_SLICE])
        assert np.abs(again - clip.features).max() < 1e-4, clip.name
        # Rotations from the 6D are proper rotations, and FK of their local form on the model
        # skeleton reproduces the positions (the rotation and position parts agree).
        from ardy_export.data.skeleton import local_from_global_rotations

        local = local_from_global_rotations(rotations)
        _, fk_positions = fk(local, positions[:, 0], default_skeleton().offsets)
        assert np.abs(fk_positions - positions).max() < 2e-3, clip.name


@pytest.mark.requires_data
def test_feature_slices_hold_what_they_say() -> None:
    clip = real_clips()[5]  # dataset-2 walk
    _, positions = motion_from_features(clip.features)
    f = clip.features.astype(np.float64)
    np.testing.assert_allclose(f[:, POS_SLICE], positions[:, 0], atol=1e-6)
    np.testing.assert_allclose(np.hypot(f[:, 3], f[:, 4]), 1.0, atol=1e-6)
    planar = positions[:, 0] * [1.0, 0.0, 1.0]
    np.testing.assert_allclose(
        f[:, JOINT_POS_SLICE].reshape(-1, 20, 3), positions[:, 1:] - planar[:, None], atol=1e-6
    )
    velocities = f[:, JOINT_VEL_SLICE].reshape(-1, 21, 3)
    np.testing.assert_allclose(velocities[1:], np.diff(positions, axis=0) * 20.0, atol=1e-3)
    np.testing.assert_allclose(velocities[0], velocities[1], atol=1e-6)
    assert set(np.unique(f[:, CONTACT_SLICE])) <= {0.0, 1.0}
    # the character walks forward: root velocity along its heading
    forward = np.stack([f[:, 4], np.zeros(len(f)), f[:, 3]], axis=-1)  # (sin psi, 0, cos psi)
    assert np.mean(np.sum(velocities[:, 0] * forward, axis=-1)) > 0.5


def test_contacts_follow_thresholds() -> None:
    thresholds = load_data_config().contacts
    positions = np.zeros((3, 21, 3))
    positions[:, :, 1] = 1.0
    positions[0, list(FOOT_JOINTS), 1] = 0.01  # low and (velocity below) slow
    velocities = np.zeros_like(positions)
    velocities[0, FOOT_JOINTS[0]] = [1.0, 0.0, 0.0]  # fast Foot_L
    contacts = compute_contacts(positions, velocities, thresholds=thresholds)
    np.testing.assert_array_equal(contacts[0], [0, 1, 1, 1])
    np.testing.assert_array_equal(contacts[1:], 0)


@pytest.mark.requires_data
def test_dataset_foot_skate_is_low_and_plausible() -> None:
    clips = real_clips()
    features = [c.features for c in clips]
    by_labels = foot_skate_from_contacts(features)
    by_height = foot_skate(features)
    ratio = contact_ratio(features)
    print(
        f"\nfoot skate of {len(clips)} real clips: {by_labels:.4f} m/s over labelled contacts, "
        f"{by_height:.4f} m/s by height (paper's metric); contact ratio {ratio.round(2)}"
    )
    assert 0.002 < by_labels < 0.06
    assert 0.02 < by_height < 0.6
    assert by_labels < by_height
    assert np.all((ratio > 0.2) & (ratio < 0.95))


@pytest.mark.requires_data
def test_recenter_round_trip() -> None:
    clip = max(real_clips(), key=lambda c: c.frames)
    centred, offset = recenter(clip.features, 10)
    assert centred[10, 0] == 0.0 and centred[10, 2] == 0.0
    assert offset[1] == 0.0
    changed = np.nonzero(np.any(centred != clip.features, axis=0))[0]
    assert set(changed) <= {0, 2}
    np.testing.assert_allclose(uncenter(centred, offset), clip.features, atol=1e-6)
    batch = np.stack([clip.features[:40], clip.features[40:80]])
    centred_batch, offsets = recenter(batch, -1)
    np.testing.assert_allclose(centred_batch[:, -1, [0, 2]], 0.0, atol=1e-6)
    np.testing.assert_allclose(uncenter(centred_batch, offsets), batch, atol=1e-6)


@pytest.mark.requires_data
def test_normalization_stats(tmp_path: Path) -> None:
    clips = real_clips()
    stats = compute_normalization_stats(clips, seed=1)
    assert stats.mean.shape == stats.std.shape == (FEATURE_SIZE,)
    assert stats.mean.dtype == np.float32
    assert np.all(stats.std >= 0.01 - 1e-7)
    np.testing.assert_allclose(stats.mean[CONTACT_SLICE], 0.5)
    np.testing.assert_allclose(stats.std[CONTACT_SLICE], 0.5)
    # yaw augmentation makes the heading isotropic
    assert np.all(np.abs(stats.mean[HEADING_SLICE]) < 0.3)
    x = clips[0].features
    np.testing.assert_allclose(stats.denormalize(stats.normalize(x)), x, atol=1e-4)
    stats.save(tmp_path / "norm.npz")
    loaded = NormalizationStats.load(tmp_path / "norm.npz")
    np.testing.assert_array_equal(loaded.mean, stats.mean)
    np.testing.assert_array_equal(loaded.std, stats.std)
    assert loaded.info == stats.info
    import json

    from_dict = NormalizationStats.from_dict(json.loads(json.dumps(stats.to_dict())))
    np.testing.assert_array_equal(from_dict.std, stats.std)
    with pytest.raises(ValueError, match="positive"):
        NormalizationStats(np.zeros(3), np.array([1.0, 0.0, 1.0]))
