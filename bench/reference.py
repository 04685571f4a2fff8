"""The same windows in the PyTorch reference sampler (export_tools ardy_export.sampling), for
the C++/PyTorch ratio of bench/run.sh: one window (DDIM with every guidance row, root
overwrite, decoding with 4 context tokens, features, FK) at 4 steps with a full history for
ardy-bench's three cases (text only: no goals; waypoints every 3 s; full: a dense path), the
full case at 10 steps, and one denoiser call with the full case's three guidance rows. The
reference is the uncached ``Denoiser.forward`` (every call recomputes the history). Prints
JSON.

    .venv/bin/python bench/reference.py --checkpoint build/bench_model/reference.pt --threads 2
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "export_tools"))

from ardy_export.sampling.constraints import (
    RootWaypoint,
    path_from_polyline,
    window_goals,
)
from ardy_export.sampling.guidance import guidance_branches
from ardy_export.sampling.sampler import (
    ModelBundle,
    WindowRequest,
    _pack_rows,
    call_denoiser,
    decode_window,
    features_to_motion,
    sample_windows,
    window_features,
)


def timed(fn: Callable[[], object], repeats: int, warmup: int = 2) -> list[float]:
    for _ in range(warmup):
        fn()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(1000.0 * (time.perf_counter() - t0))
    return out


def summary(ms: list[float]) -> dict[str, float]:
    v = sorted(ms)
    return {
        "p50": v[(len(v) - 1) // 2],
        "p99": v[int(np.ceil(0.99 * len(v))) - 1],
        "mean": float(np.mean(v)),
        "max": v[-1],
        "count": len(v),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("--checkpoint", required=True)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--json", default="")
    parser.add_argument(
        "--future-tokens", type=int, default=-1, help="-1: the model's maximum"
    )
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    bundle = ModelBundle.from_checkpoint(args.checkpoint)
    cfg = bundle.config
    h, c = cfg.max_history_tokens, cfg.window_tokens
    f = (
        cfg.max_future_tokens
        if args.future_tokens < 0
        else min(args.future_tokens, cfg.max_future_tokens)
    )
    rng = np.random.default_rng(0)
    history = rng.standard_normal((h, cfg.token_dim)).astype(np.float32)
    text = rng.standard_normal(cfg.text_dim).astype(np.float32)
    noise = rng.standard_normal((c, cfg.token_dim)).astype(np.float32)
    fps = 20.0
    every = int(3 * fps)
    constraints = {
        "text": [],
        "waypoints": [
            RootWaypoint(frame, 0.0, 1.2 * frame / fps)
            for frame in range(every, 8000, every)
        ],
        "full": [path_from_polyline([(0.0, 0.0), (0.0, 400.0)], 1.2, 0)],
    }
    assert bundle.skeleton is not None
    skeleton = bundle.skeleton
    k = min(h, 4)

    def request_for(case: str) -> WindowRequest:
        goals = window_goals(
            constraints[case], 0, (0.0, 0.0), bundle.mean, bundle.std, c, f
        )
        return WindowRequest(history, text, goals, noise)

    @torch.no_grad()
    def window(request: WindowRequest, steps: int) -> None:
        (x0,) = sample_windows(bundle.denoiser, bundle.schedule, [request], steps)
        prev = (
            history[h - k - 1, 5 * (cfg.patch - 1) : 5 * cfg.patch] if h > k else None
        )
        body = decode_window(bundle, history[h - k :], x0, prev)
        feats = window_features(x0, body, bundle.mean, bundle.std, (0.0, 0.0))
        features_to_motion(feats, skeleton)

    full = request_for("full")
    branches = [guidance_branches(2.0, 2.0, True, full.goals.has_constraints)]
    packed = _pack_rows([full], branches, cfg)
    rows = len(branches[0])
    x_t = torch.from_numpy(noise).unsqueeze(0).expand(rows, -1, -1).contiguous()
    step = torch.full((rows,), cfg.diffusion_steps - 1, dtype=torch.int64)

    @torch.no_grad()
    def denoiser_call() -> None:
        call_denoiser(bundle.denoiser, x_t, step, packed)

    cases = {}
    for case in constraints:
        request = request_for(case)
        cases[case] = {
            "rows": len(
                guidance_branches(2.0, 2.0, True, request.goals.has_constraints)
            ),
            "future_tokens": int(request.goals.future_tokens),
            "window_4_ms": summary(timed(lambda r=request: window(r, 4), args.repeats)),
        }
    result = {
        "torch": torch.__version__,
        "threads": torch.get_num_threads(),
        "history_tokens": h,
        "cases": cases,
        "window_10_ms": summary(
            timed(lambda: window(full, 10), max(3, args.repeats // 2))
        ),
        "denoiser_call_ms": summary(timed(denoiser_call, args.repeats * 2)),
    }
    text_json = json.dumps(result, indent=1)
    if args.json:
        Path(args.json).write_text(text_json + "\n", encoding="utf-8")
    print(text_json)


if __name__ == "__main__":
    main()
