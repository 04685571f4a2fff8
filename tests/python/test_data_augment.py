"""Mirror and yaw augmentation."""

from __future__ import annotations

import numpy as np
import pytest

from ardy_export.data.augment import (
    mirror_clip,
    mirror_features,
    mirror_labels,
    random_yaw,
    rotate_yaw,
)
from ardy_export.data.contacts import compute_contacts
from ardy_export.data.features import (
    CONTACT_SLICE,
    HEADING_SLICE,
    JOINT_VEL_SLICE,
    features_from_motion,
    motion_from_features,
    positions_from_features,
)
from ardy_export.data.labels import MIRROR_CONTENT, mirror_content
from ardy_export.data.skeleton import (
    JOINT_INDEX,
    default_skeleton,
    fk,
    local_from_global_rotations,
)
from test_data_common import real_clips

# Every test here runs on the real Bandai Namco clips.
pytestmark = pytest.mark.requires_data


def test_mirror_twice_is_identity() -> None:
    for clip in real_clips():
        once = mirror_features(clip.features)
        assert not np.array_equal(once, clip.features)
        np.testing.assert_array_equal(mirror_features(once), clip.features)


def test_mirror_is_a_consistent_motion() -> None:
    """The mirrored features are the features of the mirrored pose: recomputing them from the
    mirrored rotations and positions (heading, velocities, contacts) gives the same vector,
    and FK of the mirrored rotations on the model skeleton gives the mirrored positions."""
    offsets = default_skeleton().offsets
    for clip in real_clips():
        mirrored = mirror_features(clip.features)
        rotations, positions = motion_from_features(mirrored)
        original = positions_from_features(clip.features)
        left, right = JOINT_INDEX["Hand_L"], JOINT_INDEX["Hand_R"]
        np.testing.assert_allclose(positions[:, left], original[:, right] * [-1, 1, 1], atol=1e-6)
        contacts = compute_contacts(positions, mirrored[:, JOINT_VEL_SLICE].reshape(-1, 21, 3))
        np.testing.assert_array_equal(contacts, mirrored[:, CONTACT_SLICE])
        again = features_from_motion(rotations, positions, 20.0, mirrored[:, CONTACT_SLICE])
        assert np.abs(again - mirrored).max() < 1e-4, clip.name
        _, fk_positions = fk(local_from_global_rotations(rotations), positions[:, 0], offsets)
        assert np.abs(fk_positions - positions).max() < 2e-3, clip.name


def test_mirror_swaps_labels() -> None:
    assert mirror_labels("walk-left", "happy") == ("walk-right", "happy")
    assert mirror_labels("walk-turn-right", "elderly") == ("walk-turn-left", "elderly")
    assert mirror_content("wave-left-hand") == "wave-right-hand"
    assert mirror_content("raise-up-right-hand") == "raise-up-left-hand"
    for symmetric in ("walk", "run", "wave-both-hands", "raise-up-both-hands", "bow", "kick"):
        assert mirror_content(symmetric) == symmetric
    for content, other in MIRROR_CONTENT.items():
        assert MIRROR_CONTENT[other] == content
        assert content.replace("left", "#").replace("right", "left").replace("#", "right") == other
    clip = next(c for c in real_clips() if c.content == "walk-turn-left")
    mirrored = mirror_clip(clip)
    assert (mirrored.content, mirrored.style) == ("walk-turn-right", clip.style)
    assert mirrored.name.endswith("_mirror")
    assert mirror_clip(mirrored).name == clip.name


def test_mirrored_turn_turns_the_other_way() -> None:
    def turn(features: np.ndarray) -> float:
        psi = np.unwrap(np.arctan2(features[:, HEADING_SLICE.start + 1], features[:, 3]))
        return float(psi[-1] - psi[0])

    clips = {c.content: c for c in real_clips() if c.dataset == "dataset-2"}
    left = clips["walk-turn-left"].features
    right = clips["walk-turn-right"].features
    assert turn(left) > 0.5 > -0.5 > turn(right)  # a left turn raises psi (Y up)
    assert turn(mirror_features(left)) == pytest.approx(-turn(left), abs=1e-5)


def test_yaw_preserves_speeds_and_heights() -> None:
    rng = np.random.default_rng(5)
    for clip in real_clips():
        rotated, angle = random_yaw(clip.features, rng)
        before = positions_from_features(clip.features)
        after = positions_from_features(rotated)
        np.testing.assert_allclose(after[..., 1], before[..., 1], atol=1e-5)
        v0 = clip.features[:, JOINT_VEL_SLICE].reshape(-1, 21, 3)
        v1 = rotated[:, JOINT_VEL_SLICE].reshape(-1, 21, 3)
        np.testing.assert_allclose(
            np.linalg.norm(v1, axis=-1), np.linalg.norm(v0, axis=-1), atol=1e-4
        )
        np.testing.assert_array_equal(rotated[:, CONTACT_SLICE], clip.features[:, CONTACT_SLICE])
        psi0 = np.arctan2(clip.features[:, 4], clip.features[:, 3])
        psi1 = np.arctan2(rotated[:, 4], rotated[:, 3])
        np.testing.assert_allclose(np.angle(np.exp(1j * (psi1 - psi0 - angle))), 0.0, atol=1e-5)
        # consistent: recomputing the features from the rotated pose gives the same vector
        rotations, positions = motion_from_features(rotated)
        again = features_from_motion(rotations, positions, 20.0, rotated[:, CONTACT_SLICE])
        assert np.abs(again - rotated).max() < 1e-4
        np.testing.assert_allclose(rotate_yaw(rotated, -angle), clip.features, atol=1e-5)


def test_yaw_about_a_pivot_frame_keeps_that_root() -> None:
    clip = max(real_clips(), key=lambda c: c.frames)
    rotated = rotate_yaw(clip.features, 1.0, pivot_frame=7)
    np.testing.assert_allclose(rotated[7, :3], clip.features[7, :3], atol=1e-5)
