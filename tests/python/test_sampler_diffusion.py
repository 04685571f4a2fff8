"""Diffusion schedule, DDIM timesteps and steps, guidance rows (packing and skipping)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch

from ardy_export.diffusion import DiffusionSchedule, cosine_alphas_cumprod, ddim_timesteps
from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser
from ardy_export.sampling.constraints import WindowGoals
from ardy_export.sampling.guidance import combine, guidance_branches, is_late_step
from ardy_export.sampling.sampler import WindowRequest, sample_windows
from ardy_export.sampling.tiny import random_bundle

torch.set_num_threads(1)


def test_schedule_is_monotone_and_serializable() -> None:
    ab = cosine_alphas_cumprod(10)
    assert ab.shape == (10,) and np.all(np.diff(ab) < 0) and 0 < ab[-1] < 1e-3 < ab[0] < 1
    s = DiffusionSchedule.cosine(10)
    again = DiffusionSchedule.from_dict(s.to_dict())
    assert np.array_equal(again.alphas_cumprod, s.alphas_cumprod)


@pytest.mark.parametrize("n", [1, 4, 10, 20])
def test_ddim_timesteps_rule(n: int) -> None:
    for s in range(1, n + 1):
        ts = ddim_timesteps(n, s)
        assert len(ts) == s and ts[0] == n - 1
        assert all(a > b for a, b in itertools.pairwise(ts))  # strictly decreasing
        if s > 1:
            assert ts[-1] == 0
    assert ddim_timesteps(10, 4) == [9, 6, 3, 0]
    with pytest.raises(ValueError):
        ddim_timesteps(n, n + 1)


def _empty_goals(c: int, gd: int) -> WindowGoals:
    z = np.zeros((c, gd), np.float32)
    return WindowGoals(
        z, z, np.zeros((0, gd), np.float32), np.zeros((0, gd), np.float32), np.zeros(0, np.float32)
    )


class _Oracle(torch.nn.Module):
    """Predicts a fixed x0 whatever the input (records the calls)."""

    def __init__(self, target: torch.Tensor, config: object) -> None:
        super().__init__()
        self.target = target
        self.config = config
        self.calls: list[dict[str, torch.Tensor]] = []

    def forward(self, x_t: torch.Tensor, step: torch.Tensor, *rest: torch.Tensor) -> torch.Tensor:
        self.calls.append(
            {
                "x_t": x_t.clone(),
                "step": step.clone(),
                "text_keep": rest[1].clone(),
                "constraint_keep": rest[9].clone(),
                "history": rest[2].clone(),
            }
        )
        return self.target.expand(x_t.shape[0], -1, -1).clone()


@pytest.mark.parametrize("steps", range(1, 11))
def test_ddim_with_an_exact_model_returns_its_x0(steps: int) -> None:
    bundle = random_bundle()
    cfg = bundle.config
    target = torch.randn(1, cfg.window_tokens, cfg.token_dim)
    oracle = _Oracle(target, cfg)
    req = WindowRequest(
        np.zeros((0, cfg.token_dim), np.float32),
        None,
        _empty_goals(cfg.window_tokens, cfg.goal_dim),
        np.random.default_rng(0)
        .standard_normal((cfg.window_tokens, cfg.token_dim))
        .astype(np.float32),
    )
    (x0,) = sample_windows(oracle, bundle.schedule, [req], steps)  # type: ignore[arg-type]
    assert np.allclose(x0, target[0].numpy(), atol=1e-6)
    assert [int(c["step"][0]) for c in oracle.calls] == ddim_timesteps(10, steps)
    # x_T is the noise; with an exact model the implied eps stays (x_T - a_T x0) / b_T, and
    # every later x_t is a_t x0 + b_t eps
    a_t, b_t = bundle.schedule.coefficients(9)
    eps = (torch.from_numpy(req.noise) - a_t * target[0]) / b_t
    assert torch.allclose(oracle.calls[0]["x_t"][0], torch.from_numpy(req.noise))
    for call, t in zip(oracle.calls[1:], ddim_timesteps(10, steps)[1:], strict=True):
        a, b = bundle.schedule.coefficients(t)
        expect = a * target[0] + b * eps
        assert torch.allclose(call["x_t"][0], expect, atol=1e-5)


def test_ddim_step_is_the_deterministic_update() -> None:
    s = DiffusionSchedule.cosine(10)
    x0 = torch.randn(3, 4)
    eps = torch.randn(3, 4)
    x_t = s.q_sample(x0, torch.full((3,), 7), eps)
    x_next = s.ddim_step(x_t, x0, 7, 2)
    a, b = s.coefficients(2)
    assert torch.allclose(x_next, a * x0 + b * eps, atol=1e-5)


@pytest.mark.parametrize(
    ("w_text", "w_con", "has_text", "has_con", "names"),
    [
        (2.0, 2.0, True, True, ["uncond", "text", "constraint"]),
        (2.0, 2.0, True, False, ["uncond", "text"]),
        (2.0, 2.0, False, True, ["uncond", "constraint"]),
        (0.0, 2.0, True, True, ["uncond", "constraint"]),
        (2.0, 0.0, True, True, ["uncond", "text"]),
        (1.0, 0.0, True, True, ["text"]),
        (0.0, 0.0, True, True, ["uncond"]),
        (0.5, 0.5, True, True, ["text", "constraint"]),
    ],
)
def test_guidance_branches(
    w_text: float, w_con: float, has_text: bool, has_con: bool, names: list[str]
) -> None:
    brs = guidance_branches(w_text, w_con, has_text, has_con)
    assert [b.name for b in brs] == names
    d0, dt, dc = torch.randn(3, 5, 7).unbind(0)
    rows = {"uncond": d0, "text": dt, "constraint": dc}
    got = combine(torch.stack([rows[b.name] for b in brs]), brs)
    wt = w_text if has_text else 0.0
    wc = w_con if has_con else 0.0
    assert torch.allclose(got, d0 + wt * (dt - d0) + wc * (dc - d0), atol=1e-5)
    assert torch.equal(combine(torch.stack([rows[b.name] for b in brs]), brs, late=True), got)


def test_guidance_branches_with_another_late_text_weight() -> None:
    """w_text 1.5 early and 1 late: D0 weighs -0.5 early and 0 late, so it is evaluated;
    each step combines with its own weights (tests/cpp/test_sampler.cpp)."""
    brs = guidance_branches(1.5, 2.0, True, False, late_w_text=1.0)
    assert [(b.name, b.weight, b.late_weight) for b in brs] == [
        ("uncond", -0.5, 0.0),
        ("text", 1.5, 1.0),
    ]
    d0, dt = torch.randn(2, 5, 7).unbind(0)
    outputs = torch.stack((d0, dt))
    assert torch.allclose(combine(outputs, brs), d0 + 1.5 * (dt - d0), atol=1e-6)
    assert torch.allclose(combine(outputs, brs, late=True), dt, atol=1e-6)
    assert [is_late_step(t, 1000) for t in (999, 666, 500, 499, 333, 0)] == [
        False,
        False,
        False,
        True,
        True,
        True,
    ]


def test_one_call_evaluates_all_rows_of_all_windows() -> None:
    """Two windows (text+constraints, and text only) with different history lengths go in one
    batch per step: 3 + 2 rows with the right keep flags and front-padded histories."""
    bundle = random_bundle()
    cfg = bundle.config
    c, d, gd = cfg.window_tokens, cfg.token_dim, cfg.goal_dim
    rng = np.random.default_rng(1)
    g = _empty_goals(c, gd)
    wm = g.window_goal_mask.copy()
    wm[0, 0] = 1.0
    g_con = WindowGoals(g.window_goal, wm, g.future_goal, g.future_goal_mask, g.future_mask)
    emb = rng.standard_normal(384).astype(np.float32)
    reqs = [
        WindowRequest(
            rng.standard_normal((3, d)).astype(np.float32),
            emb,
            g_con,
            rng.standard_normal((c, d)).astype(np.float32),
        ),
        WindowRequest(
            rng.standard_normal((1, d)).astype(np.float32),
            emb,
            g,
            rng.standard_normal((c, d)).astype(np.float32),
        ),
    ]
    oracle = _Oracle(torch.zeros(1, c, d), cfg)
    sample_windows(oracle, bundle.schedule, reqs, 2)  # type: ignore[arg-type]
    assert len(oracle.calls) == 2
    call = oracle.calls[0]
    assert call["text_keep"].tolist() == [0.0, 1.0, 0.0, 0.0, 1.0]
    assert call["constraint_keep"].tolist() == [0.0, 0.0, 1.0, 0.0, 0.0]
    assert call["history"].shape == (5, 3, d)
    assert torch.equal(call["history"][3, 2], torch.from_numpy(reqs[1].history[0]))
    assert torch.count_nonzero(call["history"][3, :2]) == 0


def test_real_denoiser_batch_equals_separate_calls() -> None:
    """Packing windows together gives the same x0 as sampling each alone."""
    bundle = random_bundle(seed=3)
    cfg = bundle.config
    c, d, gd = cfg.window_tokens, cfg.token_dim, cfg.goal_dim
    rng = np.random.default_rng(2)
    g = _empty_goals(c, gd)
    reqs = [
        WindowRequest(
            rng.standard_normal((h, d)).astype(np.float32),
            rng.standard_normal(384).astype(np.float32),
            g,
            rng.standard_normal((c, d)).astype(np.float32),
        )
        for h in (0, 2, 5)
    ]
    den: Denoiser = bundle.denoiser
    together = sample_windows(den, bundle.schedule, reqs, 4)
    for r, x in zip(reqs, together, strict=True):
        (alone,) = sample_windows(den, bundle.schedule, [r], 4)
        assert np.allclose(alone, x, atol=1e-4)


def _path_goals(c: int, p: int, path_frames: int, extra_feature: int | None = None) -> WindowGoals:
    """Root x and z given on the first ``path_frames`` of the window's ``c * p`` frames;
    ``extra_feature`` also constrains that feature on the first frame."""
    m = L.FEATURE_SIZE
    goal = np.zeros((c * p, m), np.float32)
    mask = np.zeros((c * p, m), np.float32)
    goal[:path_frames, 0] = np.linspace(0.0, 1.0, path_frames)
    mask[:path_frames, [0, 2]] = 1.0
    if extra_feature is not None:
        mask[0, extra_feature] = 1.0
    empty = np.zeros((0, p * m), np.float32)
    return WindowGoals(
        goal.reshape(c, p * m), mask.reshape(c, p * m), empty, empty, np.zeros(0, np.float32)
    )


def test_root_path_only_marks_a_dense_root_path_alone() -> None:
    c, p = 10, 4
    assert _path_goals(c, p, 40).root_path_only
    assert _path_goals(c, p, 20).root_path_only  # half the window: the bound
    assert _path_goals(c, p, 20, extra_feature=L.HEADING_SLICE.start).root_path_only
    assert not _path_goals(c, p, 19).root_path_only
    assert not _path_goals(c, p, 40, extra_feature=L.HEADING_SLICE.stop).root_path_only
    assert not _empty_goals(c, p * L.FEATURE_SIZE).root_path_only


def test_path_guidance_scale_scales_w_con_on_dense_path_windows_only() -> None:
    """On a dense-path window, w_con 2 at scale 0.5 samples as w_con 1; elsewhere the
    scale changes nothing."""
    bundle = random_bundle(seed=3)
    cfg = bundle.config
    c, d = cfg.window_tokens, cfg.token_dim
    rng = np.random.default_rng(5)
    text = rng.standard_normal(384).astype(np.float32)
    noise = rng.standard_normal((c, d)).astype(np.float32)

    def sample(goals: WindowGoals, w_con: float, scale: float) -> np.ndarray:
        request = WindowRequest(np.zeros((0, d), np.float32), text, goals, noise)
        (x0,) = sample_windows(
            bundle.denoiser, bundle.schedule, [request], 4, 2.0, w_con, True, scale
        )
        return x0

    path = _path_goals(c, cfg.patch, c * cfg.patch)
    assert np.allclose(sample(path, 2.0, 0.5), sample(path, 1.0, 1.0), atol=1e-6)
    assert not np.allclose(sample(path, 2.0, 0.5), sample(path, 2.0, 1.0), atol=1e-3)
    keyframe = _path_goals(c, cfg.patch, c * cfg.patch, extra_feature=L.HEADING_SLICE.stop)
    assert np.allclose(sample(keyframe, 2.0, 0.5), sample(keyframe, 2.0, 1.0), atol=1e-6)


def test_text_only_guidance_scale_scales_w_text_on_windows_without_goals_only() -> None:
    """Without goals, w_text 2 at scale 1.5 samples as w_text 3 in the early steps; with goals
    the scale changes nothing (the C++ sampler's rule, tests/cpp/test_sampler.cpp)."""
    bundle = random_bundle(seed=3)
    cfg = bundle.config
    c, d = cfg.window_tokens, cfg.token_dim
    rng = np.random.default_rng(6)
    text = rng.standard_normal(384).astype(np.float32)
    noise = rng.standard_normal((c, d)).astype(np.float32)

    def sample(goals: WindowGoals, w_text: float, scale: float, steps: int = 4) -> np.ndarray:
        request = WindowRequest(np.zeros((0, d), np.float32), text, goals, noise)
        (x0,) = sample_windows(
            bundle.denoiser, bundle.schedule, [request], steps, w_text, 2.0, True, 1.0, scale
        )
        return x0

    free = _empty_goals(c, cfg.goal_dim)
    # One step is in the upper half of the schedule: the scale applies.
    assert np.allclose(sample(free, 2.0, 1.5, 1), sample(free, 3.0, 1.0, 1), atol=1e-6)
    assert not np.allclose(sample(free, 2.0, 1.5, 1), sample(free, 2.0, 1.0, 1), atol=1e-3)
    # Four steps: the late two keep w_text 2.
    assert not np.allclose(sample(free, 2.0, 1.5), sample(free, 3.0, 1.0), atol=1e-3)
    assert not np.allclose(sample(free, 2.0, 1.5), sample(free, 2.0, 1.0), atol=1e-3)
    path = _path_goals(c, cfg.patch, c * cfg.patch)
    assert np.allclose(sample(path, 2.0, 1.5), sample(path, 2.0, 1.0), atol=1e-6)
