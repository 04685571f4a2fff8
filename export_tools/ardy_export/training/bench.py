"""Parameter counts and PyTorch CPU speeds of model sizes (``python -m
ardy_export.training.bench``): training steps/s, one denoiser call at batch 3 (the three
guidance rows) and one full window (DDIM steps, guidance, decoding, FK)."""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
import torch

from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.graphs import example_denoiser_inputs
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig
from ardy_export.sampling.constraints import path_from_polyline, window_goals
from ardy_export.sampling.sampler import (
    ModelBundle,
    WindowRequest,
    decode_window,
    features_to_motion,
    sample_windows,
    window_features,
)
from ardy_export.sampling.tiny import synthetic_stats
from ardy_export.training.synthetic import synthetic_skeleton

SIZES: dict[str, dict[str, int]] = {
    "tiny": {"width": 64, "layers": 2, "heads": 4},
    "small": {"width": 128, "layers": 3, "heads": 4},
    "medium": {"width": 192, "layers": 4, "heads": 4},
    "default": {"width": 256, "layers": 4, "heads": 4},
}


def count(module: torch.nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())


def timed(fn: Callable[[], object], repeats: int, warmup: int = 3) -> float:
    """Median wall time of ``fn`` in milliseconds."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * float(np.median(times))


def build(size: dict[str, int], latent: int, max_future: int) -> ModelBundle:
    torch.manual_seed(0)
    tcfg = TokenizerConfig(body_dim=L.BODY_DIM, latent_dim=latent, **size)
    dcfg = DenoiserConfig(latent_dim=latent, max_future_tokens=max_future, **size)
    mean, std = synthetic_stats()
    from ardy_export.diffusion import DiffusionSchedule

    return ModelBundle(
        BodyTokenizer(tcfg),
        Denoiser(dcfg),
        DiffusionSchedule.cosine(10),
        mean,
        std,
        np.zeros(latent, np.float32),
        np.ones(latent, np.float32),
        synthetic_skeleton(),
    )


@torch.no_grad()
def one_window(bundle: ModelBundle, history: int, steps: int, decode_context: int) -> None:
    cfg = bundle.config
    rng = np.random.default_rng(0)
    hist = rng.standard_normal((history, cfg.token_dim)).astype(np.float32)
    path = path_from_polyline([(0.0, 0.0), (0.0, 20.0)], 1.2, 0)
    goals = window_goals([path], 0, (0.0, 0.0), bundle.mean, bundle.std, 10, 10)
    req = WindowRequest(
        hist,
        rng.standard_normal(384).astype(np.float32),
        goals,
        rng.standard_normal((10, cfg.token_dim)).astype(np.float32),
    )
    (x0,) = sample_windows(bundle.denoiser, bundle.schedule, [req], steps)
    k = min(history, decode_context)
    body = decode_window(bundle, hist[history - k :], x0, hist[history - k - 1, 15:20])
    feats = window_features(x0, body, bundle.mean, bundle.std, (0.0, 0.0))
    assert bundle.skeleton is not None
    features_to_motion(feats, bundle.skeleton)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="tiny,small,medium,default")
    parser.add_argument("--latent", type=int, default=32)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--train-batch", type=int, default=32)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    print(
        "| size | width x layers | tokenizer params | denoiser params | denoiser call B=3 "
        "H=40 F=10 (ms) | 4-step window (ms) | 10-step window (ms) | denoiser train "
        f"steps/s (B={args.train_batch}) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in args.sizes.split(","):
        size = SIZES[name]
        bundle = build(size, args.latent, 10)
        den = bundle.denoiser
        inputs = example_denoiser_inputs(den, 3, 40, 10)
        with torch.no_grad():
            call_ms = timed(lambda d=den, x=inputs: d(*x), args.repeats)
        w4 = timed(lambda b=bundle: one_window(b, 40, 4, 4), max(5, args.repeats // 4))
        w10 = timed(lambda b=bundle: one_window(b, 40, 10, 4), max(3, args.repeats // 8))
        den.train()
        opt = torch.optim.AdamW(den.parameters(), lr=1e-4)
        batch = example_denoiser_inputs(den, args.train_batch, 20, 5)

        def step(d: Denoiser = den, x: tuple = batch, o: torch.optim.Optimizer = opt) -> None:
            loss = d(*x).square().mean()
            o.zero_grad()
            loss.backward()
            o.step()

        train_ms = timed(step, 5, warmup=2)
        den.eval()
        print(
            f"| {name} | {size['width']} x {size['layers']} | {count(bundle.tokenizer) / 1e6:.2f} M"
            f" | {count(den) / 1e6:.2f} M | {call_ms:.1f} | {w4:.1f} | {w10:.1f} | "
            f"{1000.0 / train_ms:.1f} |"
        )


if __name__ == "__main__":
    main()
