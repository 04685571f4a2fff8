"""Training batches: batched yaw, tokenizer crops, denoiser windows and constraint masks."""

from __future__ import annotations

import numpy as np
import pytest

from ardy_export.models import layout as L
from ardy_export.models.denoiser import DenoiserConfig
from ardy_export.training.adapters import TextBank, TrainSequence, rotate_yaw
from ardy_export.training.batches import (
    EncodedSequence,
    WindowSamplingConfig,
    denoiser_batch,
    rotate_yaw_batch,
    sequence_weights,
    split_long,
    tokenizer_batch,
)
from ardy_export.training.constraint_sampling import (
    PATTERNS,
    ConstraintSamplingConfig,
    sample_constraint_mask,
)
from ardy_export.training.synthetic import synthetic_clips

MEAN = np.linspace(-0.2, 0.2, L.FEATURE_SIZE).astype(np.float32)
STD = np.linspace(0.5, 1.5, L.FEATURE_SIZE).astype(np.float32)


@pytest.fixture(scope="module")
def seqs() -> list[TrainSequence]:
    clips = synthetic_clips(6, seed=2)
    return [
        TrainSequence(c.name, c.features, [(0, len(c.features), (c.dataset, c.content, c.style))])
        for c in clips
    ]


def test_batched_yaw_matches_the_data_package(seqs: list[TrainSequence]) -> None:
    f = np.stack([seqs[0].features[:40], seqs[1].features[:40]])
    angles = np.array([0.7, -2.0])
    got = rotate_yaw_batch(f, angles)
    for i in range(2):
        assert np.allclose(got[i], rotate_yaw(f[i], float(angles[i])), atol=1e-5)


def test_tokenizer_crops(seqs: list[TrainSequence]) -> None:
    rng = np.random.default_rng(0)
    b = tokenizer_batch(seqs, rng, 16, 6, 4, MEAN, STD)
    assert b["body"].shape == (16, 24, 253) and b["root"].shape == (16, 24, 5)
    assert b["raw"].shape == (16, 24, 258) and b["prev_root"].shape == (16, 5)
    raw = b["raw"].numpy()
    root = b["root"].numpy() * STD[:5] + MEAN[:5]
    assert np.allclose(root, raw[..., :5], atol=1e-4)
    for i in range(16):
        if b["prev_valid"][i] == 0:  # no previous frame: re-centered on the first frame
            assert np.allclose(raw[i, 0, [0, 2]], 0.0, atol=1e-5)
            assert np.all(b["prev_root"][i].numpy() == 0)
        else:  # re-centered on the previous frame, whose normalized root is given
            prev = b["prev_root"][i].numpy() * STD[:5] + MEAN[:5]
            assert np.allclose(prev[[0, 2]], 0.0, atol=1e-5)
    # a crop longer than every sequence is shortened, not refused
    long = tokenizer_batch(seqs, rng, 2, 1000, 4, MEAN, STD)
    assert long["body"].shape[1] == (max(len(s.features) for s in seqs) // 4) * 4


def test_denoiser_windows(seqs: list[TrainSequence]) -> None:
    cfg = DenoiserConfig(latent_dim=6, max_history_tokens=5, max_future_tokens=3)
    rng = np.random.default_rng(1)
    enc = [
        EncodedSequence(
            s.features[: len(s.features) // 4 * 4],
            rng.standard_normal((len(s.features) // 4, 6)).astype(np.float32),
            s.segments,
        )
        for s in seqs
    ]
    bank = TextBank([s.segments[0][2] for s in seqs], "hashed")
    only_paths = ConstraintSamplingConfig(p_none=0.0, p_mixture=0.0, weights={"path": 1.0})
    b = denoiser_batch(enc, rng, 32, cfg, MEAN, STD, bank, only_paths, WindowSamplingConfig())
    h, f = b["history"].shape[1], b["future_mask"].shape[1]
    assert b["x0"].shape == (32, 10, cfg.token_dim) and h <= 5 and f <= 3
    assert b["window_goal"].shape == (32, 10, cfg.goal_dim)
    assert b["body"].shape == (32, 40, 253) and b["text_embedding"].shape == (32, 384)
    hm = b["history_mask"].numpy()
    assert np.all(np.diff(hm, axis=1) >= 0)  # padding first, valid history last
    for i in range(32):
        if hm[i, -1] == 1:  # re-centered on the last history frame
            last = b["history"][i, -1, 15:20].numpy() * STD[:5] + MEAN[:5]
            assert np.allclose(last[[0, 2]], 0.0, atol=1e-4)
            assert b["prev_valid"][i] == 1
        else:  # no history: re-centered on the first window frame
            first = b["x0"][i, 0, :5].numpy() * STD[:5] + MEAN[:5]
            assert np.allclose(first[[0, 2]], 0.0, atol=1e-4)
        goal = b["window_goal"][i].reshape(10, 4, 258)[..., :5].reshape(10, 20)
        mask = b["window_goal_mask"][i].reshape(10, 4, 258)[..., :5].reshape(10, 20)
        assert np.allclose((goal * mask).numpy(), (b["x0"][i, :, :20] * mask).numpy(), atol=1e-5)
    fm = b["future_mask"].numpy()
    fgm = b["future_goal_mask"].numpy()
    assert np.array_equal(fm > 0, fgm.any(axis=2))
    balanced = WindowSamplingConfig(content_balance=1.0)
    b = denoiser_batch(enc, rng, 8, cfg, MEAN, STD, bank, only_paths, balanced)
    assert b["x0"].shape == (8, 10, cfg.token_dim)
    # A balanced text share: that part of the batch (its first windows) carries no goals,
    # the rest the constraint patterns (here always a path).
    text_share = WindowSamplingConfig(content_balance=1.0, balanced_text_share=0.25)
    b = denoiser_batch(enc, rng, 8, cfg, MEAN, STD, bank, only_paths, text_share)
    has_goals = b["window_goal_mask"].flatten(1).any(1) | b["future_goal_mask"].flatten(1).any(1)
    assert has_goals.tolist() == [False] * 2 + [True] * 6
    for share, exponent in ((1.5, 1.0), (-0.1, 1.0), (0.5, 0.0)):
        with pytest.raises(ValueError, match="balanced_text_share"):
            WindowSamplingConfig(content_balance=exponent, balanced_text_share=share)


@pytest.mark.parametrize("pattern", PATTERNS)
def test_constraint_patterns_touch_their_features(pattern: str) -> None:
    cfg = ConstraintSamplingConfig(p_none=0.0, p_mixture=0.0, weights={pattern: 1.0})
    rng = np.random.default_rng(3)
    allowed = {
        "waypoints": [0, 2, 3, 4],
        "paced_waypoints": [0, 2, 3, 4],
        "path": [0, 2, 3, 4],
        "keyframes": list(range(0, L.JOINT_POS_SLICE.stop)),
        "keyframe_block": list(range(0, L.JOINT_POS_SLICE.stop)),
        "end_effectors": list(range(L.ROT6D_SLICE.start, L.JOINT_POS_SLICE.stop)),
        "contacts": list(range(L.CONTACT_SLICE.start, L.CONTACT_SLICE.stop)),
    }[pattern]
    for _ in range(20):
        mask = sample_constraint_mask(40, 16, rng, cfg)
        assert mask.any()
        cols = np.nonzero(mask.any(axis=0))[0]
        assert set(cols.tolist()) <= set(allowed)
    none = ConstraintSamplingConfig(p_none=1.0)
    assert not sample_constraint_mask(40, 16, rng, none).any()


def test_paced_waypoints_are_evenly_spaced() -> None:
    cfg = ConstraintSamplingConfig(
        p_none=0.0, p_mixture=0.0, p_window_only=0.0, weights={"paced_waypoints": 1.0}
    )
    rng = np.random.default_rng(4)
    spacings = set()
    for _ in range(50):
        frames = np.nonzero(sample_constraint_mask(40, 160, rng, cfg)[:, 0])[0]
        gaps = np.diff(frames)
        assert len(set(gaps.tolist())) == 1 and 20 <= gaps[0] <= 60
        assert frames[0] < gaps[0] and frames[-1] + gaps[0] >= 200  # over window and future
        spacings.add(int(gaps[0]))
    assert len(spacings) > 10
    # Without the pattern's weight the draw is the one configs before it had.
    old = ConstraintSamplingConfig()
    a = [sample_constraint_mask(40, 16, np.random.default_rng(s), old) for s in range(20)]
    weights = {**old.weights, "paced_waypoints": 0.0}
    zero = ConstraintSamplingConfig(weights=weights)
    b = [sample_constraint_mask(40, 16, np.random.default_rng(s), zero) for s in range(20)]
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_split_long_keeps_labels() -> None:
    seq = TrainSequence(
        "s",
        np.zeros((450, 258), np.float32),
        [(0, 300, ("d", "a", "x")), (300, 450, ("d", "b", "x"))],
    )
    parts = split_long([seq], 200)
    assert [len(p.features) for p in parts] == [200, 200, 50]  # tails < 1/4 would be dropped
    assert parts[1].segments == [(0, 100, ("d", "a", "x")), (100, 200, ("d", "b", "x"))]


def test_prefetcher_keeps_the_batch_order() -> None:
    from ardy_export.training.common import Prefetcher

    def maker(seed: int) -> object:
        rng = np.random.default_rng(seed)
        return lambda: {"x": rng.standard_normal(3)}

    inline = Prefetcher(maker(5), 0)
    ahead = Prefetcher(maker(5), 3)
    for _ in range(10):
        assert np.array_equal(next(inline)["x"], next(ahead)["x"])
    ahead.close()
    assert ahead.thread is not None and not ahead.thread.is_alive()


def test_content_balanced_draw() -> None:
    walk = [(0, 80, ("d2", "walk", "normal"))]
    bow = [(0, 80, ("d1", "bow", "happy"))]
    stitched = [(0, 40, ("d2", "walk", "normal")), (40, 80, ("d1", "bow", "sad"))]
    segments = [walk] * 30 + [bow] * 3 + [stitched] * 7
    alike = sequence_weights(segments, 0.0)
    assert np.allclose(alike, 1 / 40)
    balanced = sequence_weights(segments, 1.0)
    assert balanced.sum() == pytest.approx(1.0)
    # every content alike among the single-label sequences, which keep their 33 of 40
    assert balanced[:30].sum() == pytest.approx(balanced[30:33].sum())
    assert balanced[:33].sum() == pytest.approx(33 / 40)
    assert np.allclose(balanced[33:], 1 / 40)
    half = sequence_weights(segments, 0.5)
    assert half[:30].sum() / half[30:33].sum() == pytest.approx(np.sqrt(30 / 3))


def test_reach_shortfall_counts_only_ending_further_than_the_data() -> None:
    import torch

    from ardy_export.training.losses import reach_shortfall

    frames, future = 40, 16
    real = torch.zeros(3, frames, 5)
    real[:, -1, 2] = 2.0  # the data's window ends 2 m ahead
    pred = real.clone()
    pred[0, -1, 2] = 1.0  # 1 m short of where the data ended
    pred[1, -1, 2] = 2.5  # closer to the goal than the data: no penalty
    pred[2, -1, 2] = 0.0  # far short, but its goal lies beyond the horizon
    goal = torch.zeros(3, future, L.FEATURE_SIZE)
    mask = torch.zeros_like(goal)
    goal[:2, 2, 2] = 3.0  # a waypoint 3 frames past the window's end, 3 m ahead
    mask[:2, 2, [0, 2]] = 1.0
    goal[2, 12, 2] = 3.0
    mask[2, 12, [0, 2]] = 1.0
    keep = torch.ones(3)
    got = reach_shortfall(pred, real, goal, mask, keep, horizon=8)
    assert float(got) == pytest.approx(0.5)  # (1.0 + 0.0) / the 2 windows with a near goal
    assert float(reach_shortfall(pred, real, goal, mask, torch.zeros(3), horizon=8)) == 0.0
    assert float(reach_shortfall(pred, real, goal, mask, keep, horizon=16)) == pytest.approx(
        (1.0 + 0.0 + 2.0) / 3
    )


def test_reach_path_error_weighs_every_frame_of_windows_near_a_waypoint() -> None:
    import torch

    from ardy_export.training.losses import reach_path_error

    frames, future = 40, 16
    real = torch.zeros(2, frames, 5)
    pred = real.clone()
    pred[0, -1, 2] = 4.0  # a lunge in the last frame only: 4 m / 40 frames on average
    pred[1, :, 0] = 3.0  # 3 m off everywhere, but no waypoint near this window's end
    mask = torch.zeros(2, future, L.FEATURE_SIZE)
    mask[0, 1, [0, 2]] = 1.0
    mask[1, 12, [0, 2]] = 1.0
    keep = torch.ones(2)
    assert float(reach_path_error(pred, real, mask, keep, horizon=8)) == pytest.approx(0.1)
    assert float(reach_path_error(pred, real, mask, keep, horizon=16)) == pytest.approx(1.55)
    assert float(reach_path_error(pred, real, mask, torch.zeros(2), horizon=16)) == 0.0


def test_reach_speed_excess_counts_only_speed_above_the_datas_fastest_frame() -> None:
    import torch

    from ardy_export.training.losses import reach_speed_excess

    frames, future, fps = 40, 16, 20.0
    real = torch.zeros(2, frames, 5)
    real[:, :, 2] = torch.arange(frames) * 0.05  # 1 m/s forward, every frame
    pred = real.clone()
    pred[0, -3:, 2] += torch.tensor([0.05, 0.10, 0.15])  # the last 3 steps at 2 m/s: a lunge
    pred[1, :, 0] = torch.arange(frames) * 0.05  # sqrt(2) m/s, but no waypoint near its end
    mask = torch.zeros(2, future, L.FEATURE_SIZE)
    mask[0, 1, [0, 2]] = 1.0
    mask[1, 12, [0, 2]] = 1.0
    keep = torch.ones(2)
    lunge = 3 * 1.0 / (frames - 1)  # 1 m/s too fast over 3 of the 39 steps
    got = reach_speed_excess(pred, real, mask, keep, horizon=8, fps=fps)
    assert float(got) == pytest.approx(lunge, rel=1e-5)
    both = reach_speed_excess(pred, real, mask, keep, horizon=16, fps=fps)
    assert float(both) == pytest.approx((lunge + (2**0.5 - 1.0)) / 2, rel=1e-5)
    assert float(reach_speed_excess(real, real, mask, keep, horizon=16, fps=fps)) == 0.0
    assert float(reach_speed_excess(pred, real, mask, torch.zeros(2), horizon=16, fps=fps)) == 0.0


def test_text_bank_augmentation_stays_on_the_label_and_off_draws_as_before() -> None:
    key = ("dataset-1", "walk", "old")
    sentences = np.eye(4, 384, dtype=np.float32)  # 4 orthogonal unit "sentences"

    def bank(mix: float, noise: float) -> TextBank:
        made = TextBank([key], "hashed", mix=mix, noise=noise)
        made.embeddings[key] = sentences
        return made

    plain, off = bank(0.0, 0.0), TextBank([key], "hashed")
    off.embeddings[key] = sentences
    rng_a, rng_b = np.random.default_rng(3), np.random.default_rng(3)
    for _ in range(50):  # no augmentation: the same draws as a bank without the options
        assert np.array_equal(plain.sample(key, rng_a), off.sample(key, rng_b))
    assert rng_a.random() == rng_b.random()

    rng = np.random.default_rng(0)
    mixed = np.stack([bank(1.0, 0.0).sample(key, rng) for _ in range(400)])
    assert np.allclose(np.linalg.norm(mixed, axis=1), 1.0, atol=1e-5)
    assert np.abs(mixed[:, 4:]).max() == 0.0  # blends stay in the label's sentences' span
    blended = (mixed[:, :4] > 1e-3).sum(axis=1) == 2
    assert 0.65 < blended.mean() < 0.85  # the second draw is the first sentence 1 time in 4

    noisy = np.stack([bank(0.0, 0.5).sample(key, rng) for _ in range(400)])
    assert np.allclose(np.linalg.norm(noisy, axis=1), 1.0, atol=1e-5)
    cosine = noisy[:, :4].max(axis=1)  # against the drawn sentence
    # offsets of norm uniform in [0, 0.5], nearly orthogonal to it in 384-d
    assert cosine.min() > 1.0 / np.sqrt(1.0 + 0.5**2) - 0.02
    assert abs(float(np.median(cosine)) - 1.0 / np.sqrt(1.0 + 0.25**2)) < 0.01
    assert cosine.max() > 0.999

    with pytest.raises(ValueError, match="mix must be in"):
        TextBank([key], "hashed", mix=1.5)


def test_end_speed_excess_counts_a_lunge_in_any_windows_last_frames() -> None:
    import torch

    from ardy_export.training.losses import end_speed_excess

    frames, fps = 40, 20.0
    real = torch.zeros(3, frames, 5)
    real[:, :, 2] = torch.arange(frames) * 0.05  # 1 m/s forward, every frame
    pred = real.clone()
    pred[0, -3:, 2] += torch.tensor([0.05, 0.10, 0.15])  # the last 3 steps at 2 m/s: a lunge
    pred[1, :20, 2] = real[1, :20, 2] * 2.0  # 2 m/s early in the window, then 1 m/s (no lunge)
    pred[1, 20:, 2] = real[1, 20:, 2] + 0.95
    pred[2, -4:, 2] = real[2, -4:, 2] - 0.1  # slower at the end: not counted
    got = end_speed_excess(pred, real, fps, frames=4)
    assert float(got) == pytest.approx(3 * 1.0 / (3 * 4), rel=1e-5)  # 1 m/s over 3 of 3x4 steps
    assert float(end_speed_excess(real, real, fps, frames=4)) == 0.0
