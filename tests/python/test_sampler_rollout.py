"""Reference sampler rollout: in-window root overwrite, re-centering, prompts, history crop."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ardy_export.sampling.constraints import RootWaypoint, path_from_polyline
from ardy_export.sampling.sampler import (
    ModelBundle,
    PromptEvent,
    RolloutConfig,
    active_prompt,
    rollout,
)
from ardy_export.sampling.tiny import random_bundle
from ardy_export.training.adapters import hashed_embedding

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def bundle() -> ModelBundle:
    return random_bundle(seed=4)


def test_root_follows_an_in_window_dense_path_exactly(bundle: ModelBundle) -> None:
    path = path_from_polyline([(0.0, 0.0), (2.0, 3.0), (5.0, 3.0)], speed=1.0, start_frame=0)
    cfg = RolloutConfig(steps=4, history_tokens=8, future_tokens=4)
    res = rollout(bundle, hashed_embedding, [PromptEvent(0, "walk")], [path], 3, cfg)
    n = min(len(path.positions), len(res.features))
    assert n == 120
    assert np.allclose(res.features[:n, [0, 2]], path.positions[:n], atol=2e-4)
    assert np.allclose(res.features[:n, 3], np.cos(path.headings[:n]), atol=1e-4)
    free = rollout(bundle, hashed_embedding, [PromptEvent(0, "walk")], [], 3, cfg)
    assert np.abs(free.features[:n, [0, 2]] - path.positions[:n]).mean() > 0.1


def test_waypoint_hits_its_frame(bundle: ModelBundle) -> None:
    wp = RootWaypoint(frame=53, x=1.5, z=-0.5, heading=1.0)
    res = rollout(
        bundle, hashed_embedding, [], [wp], 2, RolloutConfig(history_tokens=8, future_tokens=4)
    )
    assert np.allclose(res.features[53, [0, 2]], [1.5, -0.5], atol=2e-4)
    assert np.allclose(res.features[53, [3, 4]], [np.cos(1.0), np.sin(1.0)], atol=1e-4)


def test_translation_equivariance_of_recentering(bundle: ModelBundle) -> None:
    """Moving the start and every constraint by (dx, dz) moves the output by the same."""
    dx, dz = 7.0, -3.0
    wp = RootWaypoint(frame=70, x=1.0, z=2.0)
    wp2 = RootWaypoint(frame=70, x=1.0 + dx, z=2.0 + dz)
    cfg = RolloutConfig(history_tokens=8, future_tokens=4)
    cfg2 = RolloutConfig(history_tokens=8, future_tokens=4, start_xz=(dx, dz))
    a = rollout(bundle, hashed_embedding, [PromptEvent(0, "run")], [wp], 3, cfg, seed=5)
    b = rollout(bundle, hashed_embedding, [PromptEvent(0, "run")], [wp2], 3, cfg2, seed=5)
    shifted = a.features.copy()
    shifted[:, 0] += dx
    shifted[:, 2] += dz
    assert np.allclose(b.features, shifted, atol=2e-3)


def test_prompt_changes_apply_at_window_starts(bundle: ModelBundle) -> None:
    prompts = [PromptEvent(0, "walk"), PromptEvent(50, "wave"), PromptEvent(80, None)]
    res = rollout(bundle, hashed_embedding, prompts, [], 4, RolloutConfig(history_tokens=8))
    assert res.window_starts == [0, 40, 80, 120]
    assert res.prompts == ["walk", "walk", None, None]
    assert active_prompt(prompts, 79) == "wave"


def test_noise_is_explicit_and_deterministic(bundle: ModelBundle) -> None:
    cfg = RolloutConfig(history_tokens=8)
    a = rollout(bundle, hashed_embedding, [PromptEvent(0, "walk")], [], 2, cfg, seed=3)
    b = rollout(bundle, hashed_embedding, [PromptEvent(0, "walk")], [], 2, cfg, seed=3)
    assert np.array_equal(a.features, b.features)
    c, d = bundle.config.window_tokens, bundle.config.token_dim
    rng = np.random.default_rng(3)
    noise = np.stack([rng.standard_normal((c, d)) for _ in range(2)]).astype(np.float32)
    e = rollout(bundle, hashed_embedding, [PromptEvent(0, "walk")], [], 2, cfg, noise=noise)
    assert np.array_equal(a.features, e.features)


def test_history_crop_and_partial_commits(bundle: ModelBundle) -> None:
    seen: list[int] = []
    original = bundle.denoiser.forward

    def spy(*args: torch.Tensor) -> torch.Tensor:
        seen.append(int(args[4].shape[1]))
        return original(*args)

    bundle.denoiser.forward = spy  # type: ignore[method-assign]
    try:
        cfg = RolloutConfig(steps=2, history_tokens=6, commit_tokens=4)
        res = rollout(bundle, hashed_embedding, [PromptEvent(0, "walk")], [], 4, cfg)
    finally:
        del bundle.denoiser.forward
    assert res.window_starts == [0, 16, 32, 48]
    assert seen[::2] == [0, 4, 6, 6]  # two steps per window; history capped at 6 tokens
    assert res.features.shape == (64, 258)
    assert res.motion is not None
    rot = res.motion.local_rotations
    eye = np.broadcast_to(np.eye(3), rot.shape)
    assert np.allclose(rot @ np.swapaxes(rot, -1, -2), eye, atol=1e-4)
    assert np.allclose(res.motion.positions[:, 0], res.features[:, :3])
