"""Tiny random-weight model bundles (tests, golden vectors of the runtime's parity tests)."""

from __future__ import annotations

import numpy as np
import torch

from ardy_export.diffusion import DiffusionSchedule
from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig
from ardy_export.sampling.sampler import ModelBundle
from ardy_export.training import synthetic


def synthetic_stats(clips: int = 12, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Feature mean/std from synthetic clips re-centred on their first frame (no data)."""
    feats = []
    for c in synthetic.synthetic_clips(clips, seed=seed):
        f = c.features.astype(np.float64).copy()
        f[:, 0] -= f[0, 0]
        f[:, 2] -= f[0, 2]
        feats.append(f)
    allf = np.concatenate(feats)
    return allf.mean(0).astype(np.float32), np.maximum(allf.std(0), 0.01).astype(np.float32)


def random_bundle(
    seed: int = 0,
    latent_dim: int = 8,
    width: int = 32,
    layers: int = 1,
    heads: int = 2,
    max_history_tokens: int = 8,
    max_future_tokens: int = 4,
    window_tokens: int = 10,
    diffusion_steps: int = 10,
    two_stage: bool = True,
    text_dim: int = 384,
    condition_modulation: bool = False,
) -> ModelBundle:
    """A bundle with random weights and synthetic statistics; deterministic for a seed. A
    condition modulation gets random weights too (a new one starts at zero, a no-op)."""
    torch.manual_seed(seed)
    tcfg = TokenizerConfig(
        body_dim=L.BODY_DIM,
        latent_dim=latent_dim,
        fsq_levels=8,
        width=width,
        layers=layers,
        heads=heads,
        ff_mult=2,
    )
    tok = BodyTokenizer(tcfg)
    mean, std = synthetic_stats()
    tok.set_statistics(
        torch.from_numpy(mean[:5]),
        torch.from_numpy(std[:5]),
        torch.tensor([0.0, 0.0, 1.0, 0.9]),
        torch.tensor([1.0, 0.5, 1.0, 0.05]),
    )
    dcfg = DenoiserConfig(
        feature_dim=L.FEATURE_SIZE,
        latent_dim=latent_dim,
        window_tokens=window_tokens,
        max_history_tokens=max_history_tokens,
        max_future_tokens=max_future_tokens,
        diffusion_steps=diffusion_steps,
        width=width,
        layers=layers,
        heads=heads,
        ff_mult=2,
        two_stage=two_stage,
        text_dim=text_dim,
        condition_modulation=condition_modulation,
    )
    den = Denoiser(dcfg)
    for stage in den.stages:
        if stage.modulation is not None:
            torch.nn.init.normal_(stage.modulation.proj.weight, std=0.1)
    rng = np.random.default_rng(seed)
    return ModelBundle(
        tokenizer=tok.eval(),
        denoiser=den.eval(),
        schedule=DiffusionSchedule.cosine(diffusion_steps),
        mean=mean,
        std=std,
        latent_mean=(0.1 * rng.standard_normal(latent_dim)).astype(np.float32),
        latent_std=(0.5 + rng.random(latent_dim)).astype(np.float32),
        skeleton=synthetic.synthetic_skeleton(),
    )
