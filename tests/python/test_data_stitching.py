"""Stitched transitions between clips."""

from __future__ import annotations

import numpy as np
import pytest

from ardy_export.data.augment import mirror_clip
from ardy_export.data.features import (
    CONTACT_SLICE,
    FEATURE_SIZE,
    features_from_motion,
    motion_from_features,
)
from ardy_export.data.stitching import build_stitched_sequences, stitch_quality
from test_data_common import real_clips

# Every test here runs on the real Bandai Namco clips.
pytestmark = pytest.mark.requires_data


def pool() -> list:
    clips = real_clips()
    return clips + [mirror_clip(c) for c in clips]


def test_stitched_sequences_are_labelled_and_consistent() -> None:
    clips = pool()
    names = {(c.dataset, c.content, c.style) for c in clips}
    sequences = build_stitched_sequences(clips, np.random.default_rng(0), 6, max_seconds=12.0)
    assert len(sequences) == 6
    assert sum(len(s.joins) for s in sequences) >= 6
    for sequence in sequences:
        f = sequence.features
        assert f.dtype == np.float32 and f.shape[1] == FEATURE_SIZE
        assert np.all(np.isfinite(f))
        assert sequence.frames <= 12.0 * 20 + 1
        # segments tile the sequence, each with the labels of a real clip
        assert sequence.segments[0].start == 0
        assert sequence.segments[-1].end == sequence.frames
        for a, b in zip(sequence.segments, sequence.segments[1:], strict=False):
            assert a.end == b.start and a.end > a.start
        for segment in sequence.segments:
            assert (segment.dataset, segment.content, segment.style) in names
        assert sequence.labels_at(0) == sequence.segments[0]
        # the features are those of the stitched pose (consistent across the joins)
        rotations, positions = motion_from_features(f)
        again = features_from_motion(rotations, positions, 20.0, f[:, CONTACT_SLICE])
        assert np.abs(again - f).max() < 1e-4
        # no teleport: the root moves less than 0.5 m per frame everywhere
        assert np.linalg.norm(np.diff(positions[:, 0], axis=0), axis=-1).max() < 0.5


def test_joins_are_closer_than_random_pairs() -> None:
    clips = pool()
    rng = np.random.default_rng(1)
    sequences = build_stitched_sequences(clips, rng, 12, max_seconds=20.0)
    quality = stitch_quality(sequences, clips, rng)
    print(f"\nstitching quality on {len(clips)} clips: {quality}")
    assert quality["joins"] >= 12
    assert quality["pose_distance_ratio"] < 0.6
    # the cross-fade is smoother than a hard cut at the same joins
    assert quality["join_velocity_jump"] < quality["cut_velocity_jump"]
