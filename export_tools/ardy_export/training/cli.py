"""``ardy-export train tokenizer|denoiser`` and ``ardy-export sample``."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

import numpy as np


def _train(args: argparse.Namespace) -> int:
    from ardy_export.training.common import load_config

    config = load_config(args.config)
    if args.run_dir:
        config["run_dir"] = args.run_dir
    if args.steps:
        config.setdefault("train", {})["steps"] = args.steps
    if args.seed is not None:
        config["seed"] = args.seed
    if args.device:
        config["device"] = args.device
    if args.threads:
        config.setdefault("train", {})["threads"] = args.threads
    if args.what == "tokenizer":
        from ardy_export.training.tokenizer_train import train_tokenizer

        result = train_tokenizer(config, resume=args.resume, progress=not args.quiet)
    else:
        from ardy_export.training.denoiser_train import train_denoiser

        result = train_denoiser(config, resume=args.resume, progress=not args.quiet)
    if int(os.environ.get("RANK", "0")) != 0:
        return 0  # under torchrun only the first process reports
    last = result.history[-1] if result.history else {}
    summary = ", ".join(f"{k} {v:.4f}" for k, v in last.items() if k not in ("step", "lr"))
    print(f"{args.what}: {result.steps_per_second:.2f} steps/s; last losses: {summary}")
    print(f"checkpoint: {result.checkpoint}")
    return 0


def _sample(args: argparse.Namespace) -> int:
    from ardy_export.sampling.sampler import (
        ModelBundle,
        PromptEvent,
        RolloutConfig,
        rollout,
    )
    from ardy_export.sampling.timeline import parse_timeline
    from ardy_export.training.adapters import make_embedder

    bundle = ModelBundle.from_checkpoint(args.checkpoint, use_ema=not args.no_ema)
    prompts, constraints = [], []
    if args.timeline:
        doc = json.loads(Path(args.timeline).read_text(encoding="utf-8"))
        prompts, constraints = parse_timeline(doc)
    if args.prompt:
        prompts = [PromptEvent(0, args.prompt), *prompts]
    d = bundle.defaults
    cfg = RolloutConfig(
        steps=args.steps or int(d.get("steps", 4)),
        w_text=float(d.get("w_text", 2.0)) if args.w_text is None else args.w_text,
        w_con=float(d.get("w_con", 2.0)) if args.w_con is None else args.w_con,
        history_tokens=args.history_tokens,
        future_tokens=args.future_tokens,
    )
    window_s = bundle.config.window_tokens * bundle.config.patch / 20.0
    windows = max(1, math.ceil(args.seconds / window_s))
    result = rollout(
        bundle, make_embedder(args.text), prompts, constraints, windows, cfg, seed=args.seed
    )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    arrays = {"features": result.features, "tokens": result.tokens}
    if result.motion is not None:
        arrays.update(
            positions=result.motion.positions,
            global_rotations=result.motion.global_rotations,
            local_rotations=result.motion.local_rotations,
        )
    np.savez(out, **arrays)
    print(f"wrote {out}: {result.features.shape[0]} frames, windows at {result.window_starts}")
    return 0


def _slim(args: argparse.Namespace) -> int:
    from ardy_export.training.common import slim_checkpoint

    out = slim_checkpoint(Path(args.checkpoint), Path(args.out))
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB)")
    return 0


def _blend(args: argparse.Namespace) -> int:
    from ardy_export.training.common import blend_checkpoints

    for path in (args.first, args.second):
        if not Path(path).is_file():
            print(f"ardy-export blend-checkpoints: no checkpoint at {path}", file=sys.stderr)
            return 1
    try:
        out = blend_checkpoints(Path(args.first), Path(args.second), args.weight, Path(args.out))
    except ValueError as error:
        print(f"ardy-export blend-checkpoints: {error}", file=sys.stderr)
        return 1
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB)")
    return 0


def _attach_tokenizer(args: argparse.Namespace) -> int:
    from ardy_export.training.tokenizer_train import attach_tokenizer

    try:
        out = attach_tokenizer(Path(args.denoiser), Path(args.tokenizer), Path(args.out))
    except ValueError as error:
        print(f"ardy-export attach-tokenizer: {error}", file=sys.stderr)
        return 1
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB)")
    return 0


def add_training_commands(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    train = commands.add_parser(
        "train",
        help="train the tokenizer or the denoiser from a YAML run config",
        description=(
            "Train from a run config (configs/tokenizer.yaml, configs/denoiser.yaml). CPU by "
            "default, CUDA when present; under torchrun, one process per GPU (DDP). "
            "Checkpoints go to the run folder (latest.pt every checkpoint_every steps, "
            "final.pt at the end); --resume continues from latest.pt."
        ),
    )
    train.add_argument("what", choices=("tokenizer", "denoiser"))
    train.add_argument("--config", required=True, help="run config (YAML)")
    train.add_argument("--resume", action="store_true", help="continue from RUN_DIR/latest.pt")
    train.add_argument("--run-dir", help="override the config's run_dir")
    train.add_argument("--steps", type=int, help="override train.steps")
    train.add_argument("--seed", type=int, help="override the config's seed")
    train.add_argument("--device", choices=("auto", "cpu", "cuda"), help="override device")
    train.add_argument(
        "--threads",
        type=int,
        help="override train.threads (torch CPU threads; more when the machine frees up, "
        "e.g. resuming after an evaluation ends)",
    )
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    train.set_defaults(handler=_train)

    slim = commands.add_parser(
        "slim",
        help="keep what sampling and export need of a denoiser checkpoint (EMA weights)",
        description="Drops the raw weights, optimizer, scheduler and random states of a "
        "denoiser checkpoint: what 'export', 'sample' and init_from read remains (a third of "
        "the size).",
    )
    slim.add_argument("--checkpoint", required=True, help="denoiser checkpoint (.pt)")
    slim.add_argument("--out", required=True, help="slim checkpoint to write")
    slim.set_defaults(handler=_slim)

    blend = commands.add_parser(
        "blend-checkpoints",
        help="average two denoiser checkpoints weight by weight (fine-tunes of one model)",
        description="Writes the second checkpoint with every EMA weight (1 - w) * first + "
        "w * second (a slim checkpoint that 'export' and init_from take). Both must share the "
        "architecture and the tokenizer, e.g. two fine-tunes of one ancestor.",
    )
    blend.add_argument("--first", required=True, help="denoiser checkpoint (.pt), weight 1 - w")
    blend.add_argument("--second", required=True, help="denoiser checkpoint (.pt), weight w")
    blend.add_argument(
        "--weight", type=float, default=0.5, help="w, in [0, 1] (default: %(default)s)"
    )
    blend.add_argument("--out", required=True, help="checkpoint to write")
    blend.set_defaults(handler=_blend)

    attach = commands.add_parser(
        "attach-tokenizer",
        help="put a fine-tuned tokenizer (same encoder) into a denoiser checkpoint",
        description="Writes a copy of a denoiser checkpoint whose tokenizer is the given one "
        "(its EMA weights). The encoder must be the checkpoint's own, weight for weight (train "
        "it with train.freeze: [encoder]), so the latents the denoiser learned mean the same.",
    )
    attach.add_argument("--denoiser", required=True, help="denoiser checkpoint (.pt)")
    attach.add_argument("--tokenizer", required=True, help="tokenizer checkpoint (.pt)")
    attach.add_argument("--out", required=True, help="denoiser checkpoint to write")
    attach.set_defaults(handler=_attach_tokenizer)

    sample = commands.add_parser(
        "sample",
        help="generate motion with the PyTorch reference sampler from a denoiser checkpoint",
        description="Autoregressive rollout; writes an .npz of features, tokens and poses.",
    )
    sample.add_argument("--checkpoint", required=True, help="denoiser checkpoint (.pt)")
    sample.add_argument("--prompt", help="prompt from time 0")
    sample.add_argument("--timeline", help="JSON timeline of prompts and constraints")
    sample.add_argument("--seconds", type=float, default=6.0, help="length (default %(default)s)")
    sample.add_argument("--steps", type=int, help="DDIM steps (default: the checkpoint's)")
    sample.add_argument("--w-text", type=float, help="text guidance weight")
    sample.add_argument("--w-con", type=float, help="constraint guidance weight")
    sample.add_argument("--history-tokens", type=int, default=40)
    sample.add_argument("--future-tokens", type=int, default=10)
    sample.add_argument("--seed", type=int, default=0)
    sample.add_argument(
        "--text",
        choices=("encoder", "hashed"),
        default="encoder",
        help="prompt embeddings: MiniLM (default) or hashed (synthetic models)",
    )
    sample.add_argument("--no-ema", action="store_true", help="use the raw, not the EMA weights")
    sample.add_argument("--out", default="runs/sample.npz")
    sample.set_defaults(handler=_sample)
