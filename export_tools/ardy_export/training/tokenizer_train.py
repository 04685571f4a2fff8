"""``ardy-export train tokenizer``: train the body tokenizer from a run config."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn.parallel import DistributedDataParallel
from tqdm import tqdm

from ardy_export.models import layout as L
from ardy_export.models.layout import Skeleton
from ardy_export.models.tokenizer import (
    TOKENIZER_PARTS,
    BodyTokenizer,
    TokenizerConfig,
    local_root,
)
from ardy_export.training import adapters
from ardy_export.training.batches import split_long, tokenizer_batch
from ardy_export.training.common import (
    EMA,
    MetricsLog,
    Prefetcher,
    RunContext,
    TrainSettings,
    begin_run,
    load_config,
    make_optimizer,
    restore_rng,
    rng_state,
    run_in_context,
    run_training_steps,
    unwrap,
)
from ardy_export.training.losses import LossContext, tokenizer_loss


@dataclass
class TrainResult:
    run_dir: Path
    checkpoint: Path
    history: list[dict[str, float]] = field(default_factory=list)
    steps_per_second: float = 0.0


def skeleton_dict(skeleton: Skeleton | None) -> dict[str, Any] | None:
    if skeleton is None:
        return None
    return {
        "names": list(skeleton.names),
        "parents": list(skeleton.parents),
        "offsets": skeleton.offsets.tolist(),
    }


def prepare_sequences(data_cfg: dict[str, Any], seed: int) -> list[adapters.TrainSequence]:
    """Load (mirrored and stitched as configured) and cut sequences to ``max_seconds``."""
    seqs = adapters.load_sequences(data_cfg, np.random.default_rng(seed))
    max_frames = int(float(data_cfg.get("max_seconds", 10.0)) * L.FPS)
    return split_long(seqs, max_frames)


def local_root_stats(
    seqs: list[adapters.TrainSequence], fps: float
) -> tuple[np.ndarray, np.ndarray]:
    rows = []
    for s in seqs:
        root = torch.from_numpy(s.features[None, :, L.ROOT_SLICE].astype(np.float32))
        rows.append(local_root(root, root[:, 0], torch.zeros(1), fps)[0].numpy())
    allr = np.concatenate(rows)
    return allr.mean(0).astype(np.float32), np.maximum(allr.std(0), 1e-2).astype(np.float32)


def train_tokenizer(
    config: dict[str, Any], resume: bool = False, progress: bool = True
) -> TrainResult:
    return run_in_context(_train, config, resume, progress)


def _train(
    config: dict[str, Any],
    settings: TrainSettings,
    ctx: RunContext,
    resume: bool,
    progress: bool,
) -> TrainResult:
    seed, run_dir = begin_run(config, settings, ctx, "runs/tokenizer")
    latest = run_dir / "latest.pt"
    data_cfg = dict(config.get("data", {}))
    seqs = prepare_sequences(data_cfg, seed)
    skeleton = adapters.skeleton_for(data_cfg)

    model_cfg = dict(config.get("model", {}))
    model_cfg.setdefault("body_dim", L.BODY_DIM)
    tcfg = TokenizerConfig.from_dict(model_cfg)
    model = BodyTokenizer(tcfg)
    ckpt: dict[str, Any] | None = None
    init_from = config.get("init_from")
    if resume and latest.is_file():
        ckpt = torch.load(latest, map_location="cpu", weights_only=False)
        model = BodyTokenizer(TokenizerConfig.from_dict(ckpt["config"]))
        tcfg = model.config
        model.load_state_dict(ckpt["model"])
        mean = np.asarray(ckpt["stats"]["mean"], np.float32)
        std = np.asarray(ckpt["stats"]["std"], np.float32)
    elif init_from:
        # Fine-tuning a trained tokenizer (its own checkpoint or the one inside a denoiser
        # checkpoint): its sizes, weights and statistics are kept; the model section is
        # ignored.
        from ardy_export.training.denoiser_train import tokenizer_from_checkpoint

        model, init = tokenizer_from_checkpoint(Path(init_from))
        model = model.with_seam_parts(
            int(settings.extra.get("add_seam_filter", 0)),
            int(settings.extra.get("add_seam_overlap", 0)),
            bool(settings.extra.get("seam_overlap_contacts", True)),
        )
        model.requires_grad_(True)
        tcfg = model.config
        mean = np.asarray(init["stats"]["mean"], np.float32)
        std = np.asarray(init["stats"]["std"], np.float32)
    elif config.get("stats_file"):
        # statistics written by the data pipeline (NormalizationStats.save, an .npz)
        with np.load(Path(config["stats_file"])) as saved:
            mean = np.asarray(saved["mean"], np.float32)
            std = np.asarray(saved["std"], np.float32)
    else:
        h_frames = int(config.get("stats_history_frames", 160))
        f_frames = int(config.get("stats_future_frames", 200))
        mean, std = adapters.compute_stats(
            seqs, seed + 7, h_frames, f_frames, std_floor=float(config.get("std_floor", 0.01))
        )
    if ckpt is None and not init_from:
        lm, ls = local_root_stats(seqs, tcfg.fps)
        model.set_statistics(
            torch.from_numpy(mean[:5]),
            torch.from_numpy(std[:5]),
            torch.from_numpy(lm),
            torch.from_numpy(ls),
        )
    frozen = freeze_parts(model, [str(part) for part in settings.extra.get("freeze", [])])
    model.to(ctx.device)
    ema = EMA(model, settings.ema_decay)
    if ckpt is not None and ckpt.get("ema") is not None:
        ema.model.load_state_dict(ckpt["ema"])
        ema.updates = int(ckpt.get("ema_updates", ckpt["step"]))
    net: torch.nn.Module = model
    if ctx.distributed:
        net = DistributedDataParallel(
            model, device_ids=[ctx.device] if ctx.device.type == "cuda" else None
        )
    opt, sched = make_optimizer(model, settings)
    rng = np.random.default_rng(seed + 1000 * ctx.rank + 1)
    gen = torch.Generator().manual_seed(seed + 1000 * ctx.rank + 2)
    start = 0
    if ckpt is not None:
        opt.load_state_dict(ckpt["optimizer"])
        sched.load_state_dict(ckpt["scheduler"])
        start = int(ckpt["step"])
        if ckpt.get("rng", {}).get(str(ctx.rank)) is not None:
            restore_rng(ckpt["rng"][str(ctx.rank)], rng, gen)

    skeleton_t = None if skeleton is None else torch.from_numpy(skeleton.offsets)
    loss_ctx = LossContext(
        torch.from_numpy(mean),
        torch.from_numpy(std),
        skeleton_t,
        skeleton.parents if skeleton else L.PARENTS,
        tcfg.fps,
    ).to(ctx.device)
    weights = {k: float(v) for k, v in config.get("loss", {}).items() if k != "skate_contacts"}
    weights.setdefault("recon", 1.0)
    weights.setdefault("skate", 0.01)
    skate_contacts = str(config.get("loss", {}).get("skate_contacts", "predicted"))
    crop = settings.extra.get("crop_tokens", [4, 50])
    log = MetricsLog(run_dir / "metrics.jsonl", ctx.is_main, start if ckpt is not None else None)

    def state(step: int) -> dict[str, Any]:
        return {
            "kind": "tokenizer",
            "step": step,
            "model": unwrap(net).state_dict(),
            "ema": ema.model.state_dict(),
            "ema_updates": ema.updates,
            "config": tcfg.to_dict(),
            "run_config": {k: v for k, v in config.items() if not k.startswith("_")},
            "stats": {"mean": mean.tolist(), "std": std.tolist()},
            "skeleton": skeleton_dict(skeleton),
            "optimizer": opt.state_dict(),
            "scheduler": sched.state_dict(),
            "rng": {str(ctx.rank): rng_state(rng, gen)},
        }

    history: list[dict[str, float]] = []
    bar = tqdm(
        range(start, settings.steps),
        initial=start,
        total=settings.steps,
        disable=not (progress and ctx.is_main),
        desc="tokenizer",
        dynamic_ncols=True,
    )
    net.train()
    for name in frozen:
        getattr(model, name).eval()  # frozen parts also keep their eval behaviour

    def make_batch() -> dict[str, torch.Tensor]:
        tokens = int(rng.integers(int(crop[0]), int(crop[1]) + 1))
        return tokenizer_batch(seqs, rng, settings.batch_size, tokens, tcfg.patch, mean, std)

    final, elapsed = run_training_steps(
        bar,
        Prefetcher(make_batch, settings.prefetch),
        ctx.device,
        lambda batch: tokenizer_loss(net, batch, loss_ctx, weights, skate_contacts),  # type: ignore[arg-type]
        model,
        opt,
        sched,
        settings,
        log,
        history,
        state,
        run_dir,
        ctx.is_main,
        lambda: ema.update(unwrap(net)),
    )
    steps_run = settings.steps - start
    return TrainResult(run_dir, final, history, steps_run / elapsed if elapsed > 0 else 0.0)


def freeze_parts(model: BodyTokenizer, parts: list[str]) -> list[str]:
    """Holds the named parts (``TOKENIZER_PARTS``) fixed; returns the names of the modules
    frozen. Freezing the encoder keeps every code (and so every latent a denoiser was trained
    on) as it was while the decoder is fine-tuned."""
    unknown = [part for part in parts if part not in TOKENIZER_PARTS]
    if unknown:
        raise ValueError(
            f"train.freeze: unknown part {unknown[0]!r}; known: {', '.join(TOKENIZER_PARTS)}"
        )
    modules = [
        name
        for part in parts
        for name in TOKENIZER_PARTS[part]
        if getattr(model, name) is not None  # the seam filter is optional
    ]
    for name in modules:
        getattr(model, name).requires_grad_(False)
    return modules


def load_tokenizer(path: str | Path) -> tuple[BodyTokenizer, dict[str, Any]]:
    """A trained tokenizer (eval mode, frozen; its EMA weights when it has them) and its
    checkpoint dict."""
    ckpt = torch.load(Path(path), map_location="cpu", weights_only=False)
    if ckpt.get("kind") != "tokenizer":
        raise ValueError(f"{path}: not a tokenizer checkpoint (kind {ckpt.get('kind')!r})")
    tok = BodyTokenizer(TokenizerConfig.from_dict(ckpt["config"]))
    tok.load_state_dict(ckpt.get("ema") or ckpt["model"])
    tok.eval()
    for p in tok.parameters():
        p.requires_grad_(False)
    return tok, ckpt


def attach_tokenizer(denoiser: Path, tokenizer: Path, out: Path) -> Path:
    """A copy of a denoiser checkpoint with the tokenizer of a tokenizer checkpoint (its EMA
    weights), refused unless the configs, statistics and encoder weights are the denoiser's
    own (then every latent it was trained on decodes through the new decoder)."""
    ckpt = torch.load(denoiser, map_location="cpu", weights_only=False)
    if ckpt.get("kind") != "denoiser":
        raise ValueError(f"{denoiser}: not a denoiser checkpoint (kind {ckpt.get('kind')!r})")
    tok, tok_ckpt = load_tokenizer(tokenizer)
    # The seam parts are the decoder's own: the codes the denoiser learned stay as they were.
    base_config = TokenizerConfig.from_dict(ckpt["tokenizer_config"])
    if tok.config.without_seam_parts() != base_config.without_seam_parts():
        raise ValueError(f"{tokenizer}: its tokenizer config differs from {denoiser}'s")
    if tok_ckpt["stats"] != ckpt["stats"]:
        raise ValueError(f"{tokenizer}: its feature statistics differ from {denoiser}'s")
    state = tok.state_dict()
    for name in TOKENIZER_PARTS["encoder"]:
        prefix = name + "."
        for key, value in state.items():
            if key.startswith(prefix) and not torch.equal(value, ckpt["tokenizer"][key]):
                raise ValueError(
                    f"{tokenizer}: encoder weight {key} differs from {denoiser}'s (fine-tune "
                    "with train.freeze: [encoder])"
                )
    ckpt["tokenizer"] = state
    ckpt["tokenizer_config"] = tok.config.to_dict()
    ckpt.setdefault("provenance_steps", []).append(
        {"tokenizer": str(tokenizer), "tokenizer_steps": int(tok_ckpt.get("step", 0))}
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    torch.save(ckpt, out)
    return out


def main_from_file(path: str | Path, resume: bool) -> TrainResult:
    return train_tokenizer(load_config(path), resume=resume)
