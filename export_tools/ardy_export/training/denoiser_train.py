"""``ardy-export train denoiser``: train the two-stage denoiser on a frozen tokenizer."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn.parallel import DistributedDataParallel
from tqdm import tqdm

from ardy_export.diffusion import DiffusionSchedule
from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.graphs import DecoderGraph
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig
from ardy_export.training import adapters
from ardy_export.training.batches import (
    EncodedSequence,
    WindowSamplingConfig,
    denoiser_batch,
)
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
from ardy_export.training.constraint_sampling import ConstraintSamplingConfig
from ardy_export.training.losses import LossContext, denoiser_loss
from ardy_export.training.tokenizer_train import (
    TrainResult,
    load_tokenizer,
    prepare_sequences,
    skeleton_dict,
)


@torch.no_grad()
def encode_sequences(
    tokenizer: BodyTokenizer,
    seqs: list[adapters.TrainSequence],
    mean: np.ndarray,
    std: np.ndarray,
    yaw_variants: int,
    rng: np.random.Generator,
    device: torch.device,
    latent_stats: tuple[Any, Any] | None = None,
) -> tuple[list[EncodedSequence], np.ndarray, np.ndarray]:
    """Precompute the latent tokens of every sequence under ``yaw_variants`` random yaw
    rotations with the frozen encoder; returns the encoded sequences (latents normalized)
    and the latent statistics (mean, std, clamped below at 1e-2), or ``latent_stats`` when
    given (fine-tuning keeps the trained model's)."""
    p = tokenizer.config.patch
    out: list[tuple[np.ndarray, np.ndarray, list[Any]]] = []
    tokenizer = tokenizer.to(device)
    for s in seqs:
        n = (len(s.features) // p) * p
        if n < p:
            continue
        for _ in range(max(1, yaw_variants)):
            f = adapters.rotate_yaw(s.features[:n], float(rng.uniform(-np.pi, np.pi)))
            body = torch.from_numpy(((f - mean) / std)[None, :, L.BODY_SLICE].astype(np.float32))
            codes = tokenizer.encode(body.to(device))[0].cpu().numpy()
            out.append((f.astype(np.float32), codes, s.segments))
    if latent_stats is not None:
        lmean, lstd = (np.asarray(v, np.float32) for v in latent_stats)
    else:
        allc = np.concatenate([c for _, c, _ in out])
        lmean = allc.mean(0).astype(np.float32)
        lstd = np.maximum(allc.std(0), 1e-2).astype(np.float32)
    encoded = [
        EncodedSequence(f, ((c - lmean) / lstd).astype(np.float32), segs) for f, c, segs in out
    ]
    return encoded, lmean, lstd


def tokenizer_from_checkpoint(path: Path) -> tuple[BodyTokenizer, dict[str, Any]]:
    """A frozen tokenizer and its statistics from a tokenizer checkpoint, or the one inside a
    denoiser checkpoint (e.g. the committed export_tools/checkpoints/default_denoiser.pt)."""
    ckpt = torch.load(path, map_location="cpu", weights_only=False)
    if ckpt.get("kind") != "denoiser":
        return load_tokenizer(path)
    tokenizer = BodyTokenizer(TokenizerConfig.from_dict(ckpt["tokenizer_config"]))
    tokenizer.load_state_dict(ckpt["tokenizer"])
    tokenizer.eval().requires_grad_(False)
    return tokenizer, {"stats": ckpt["stats"], "run_config": ckpt["run_config"]}


def train_denoiser(
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
    seed, run_dir = begin_run(config, settings, ctx, "runs/denoiser")
    latest = run_dir / "latest.pt"
    # init_from: fine-tune a trained denoiser checkpoint (slim or full). Its frozen tokenizer,
    # statistics and latent statistics are kept, so the latents mean what they meant.
    init: dict[str, Any] | None = None
    if config.get("init_from") and not (resume and latest.is_file()):
        init = torch.load(Path(config["init_from"]), map_location="cpu", weights_only=False)
        if init.get("kind") != "denoiser":
            raise ValueError(f"{config['init_from']}: init_from needs a denoiser checkpoint")
    tok_path = Path(config.get("tokenizer_checkpoint") or config["init_from"])
    tokenizer, tok_ckpt = tokenizer_from_checkpoint(tok_path)
    mean = np.asarray(tok_ckpt["stats"]["mean"], np.float32)
    std = np.asarray(tok_ckpt["stats"]["std"], np.float32)
    data_cfg = dict(config.get("data", tok_ckpt["run_config"].get("data", {})))
    seqs = prepare_sequences(data_cfg, seed)
    skeleton = adapters.skeleton_for(data_cfg)
    encoded, lmean, lstd = encode_sequences(
        tokenizer,
        seqs,
        mean,
        std,
        int(settings.extra.get("yaw_variants", 8)),
        np.random.default_rng(seed + 11),
        ctx.device,
        None if init is None else (init["latent_stats"]["mean"], init["latent_stats"]["std"]),
    )
    ckpt: dict[str, Any] | None = None
    if resume and latest.is_file():
        ckpt = torch.load(latest, map_location="cpu", weights_only=False)
        lmean = np.asarray(ckpt["latent_stats"]["mean"], np.float32)
        lstd = np.asarray(ckpt["latent_stats"]["std"], np.float32)
    # The sizes: a resumed run's own (its config may name only init_from, whose sizes it
    # took, and init_from is not read again on resume), else init_from's, else the config's.
    if ckpt is not None:
        model_cfg = dict(ckpt["denoiser_config"])
    elif init is not None:
        model_cfg = dict(init["denoiser_config"])
    else:
        model_cfg = dict(config.get("model", {}))
    model_cfg.update(
        feature_dim=L.FEATURE_SIZE,
        root_dim=L.ROOT_DIM,
        patch=tokenizer.config.patch,
        latent_dim=tokenizer.config.latent_dim,
        text_dim=adapters.TEXT_DIM,
    )
    # grow_layers: init_from's layers first, then identity layers up to this many per stage;
    # add_modulation: condition modulation added at zero (Denoiser.load_grown): a larger
    # model that starts from what the trained one does.
    grow_layers = config.get("grow_layers")
    if grow_layers is not None:
        model_cfg["layers"] = int(grow_layers)
    if config.get("add_modulation"):
        model_cfg["condition_modulation"] = True
    dcfg = DenoiserConfig.from_dict(model_cfg)
    schedule = DiffusionSchedule.cosine(dcfg.diffusion_steps)
    model = Denoiser(dcfg)
    ema = EMA(model, settings.ema_decay)
    if init is not None:
        model.load_grown(init["ema"])
        ema.model.load_state_dict(model.state_dict())
    if ckpt is not None:
        model.load_state_dict(ckpt["model"])
        ema.model.load_state_dict(ckpt["ema"])
        ema.updates = int(ckpt.get("ema_updates", ckpt["step"]))
    model.to(ctx.device)
    ema.model.to(ctx.device)
    decoder = (
        DecoderGraph(tokenizer, torch.from_numpy(lmean), torch.from_numpy(lstd))
        .to(ctx.device)
        .eval()
    )
    for p in decoder.parameters():
        p.requires_grad_(False)
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
    keys = [key for e in encoded for _, _, key in e.segments]
    text_cfg = dict(config.get("text", {}))
    bank = adapters.TextBank(
        keys,
        mode=str(text_cfg.get("mode", "encoder")),
        sentences=int(text_cfg.get("sentences_per_label", 16)),
        embedding_cache=text_cfg.get("embedding_cache"),
        mix=float(text_cfg.get("augment_mix", 0.0)),
        noise=float(text_cfg.get("augment_noise", 0.0)),
    )
    skeleton_t = None if skeleton is None else torch.from_numpy(skeleton.offsets)
    loss_ctx = LossContext(
        torch.from_numpy(mean),
        torch.from_numpy(std),
        skeleton_t,
        skeleton.parents if skeleton else L.PARENTS,
        tokenizer.config.fps,
    ).to(ctx.device)
    weights = {k: float(v) for k, v in config.get("loss", {}).items()}
    for k in ("hybrid", "decoded", "goal", "fk"):
        weights.setdefault(k, 1.0)
    csample = ConstraintSamplingConfig.from_dict(dict(config.get("constraints", {})))
    wsample = WindowSamplingConfig(
        text_drop=float(settings.extra.get("text_drop", 0.1)),
        constraint_drop=float(settings.extra.get("constraint_drop", 0.1)),
        content_balance=float(data_cfg.get("content_balance", 0.0)),
        balanced_text_share=float(data_cfg.get("balanced_text_share", 0.0)),
    )
    sampling_defaults = {"steps": 4, "w_text": 2.0, "w_con": 2.0}
    sampling_defaults.update(config.get("sampling", {}))
    log = MetricsLog(run_dir / "metrics.jsonl", ctx.is_main, start if ckpt is not None else None)

    def state(step: int) -> dict[str, Any]:
        return {
            "kind": "denoiser",
            "step": step,
            "model": unwrap(net).state_dict(),
            "ema": ema.state_dict(),
            "ema_updates": ema.updates,
            "denoiser_config": dcfg.to_dict(),
            "tokenizer_config": tokenizer.config.to_dict(),
            "tokenizer": tokenizer.state_dict(),
            "tokenizer_checkpoint": str(tok_path),
            "stats": {"mean": mean.tolist(), "std": std.tolist()},
            "latent_stats": {"mean": lmean.tolist(), "std": lstd.tolist()},
            "alphas_cumprod": schedule.alphas_cumprod.tolist(),
            "skeleton": skeleton_dict(skeleton),
            "sampling_defaults": sampling_defaults,
            "run_config": {k: v for k, v in config.items() if not k.startswith("_")},
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
        desc="denoiser",
        dynamic_ncols=True,
    )
    net.train()

    def make_batch() -> dict[str, torch.Tensor]:
        return denoiser_batch(
            encoded, rng, settings.batch_size, dcfg, mean, std, bank, csample, wsample
        )

    final, elapsed = run_training_steps(
        bar,
        Prefetcher(make_batch, settings.prefetch),
        ctx.device,
        lambda batch: denoiser_loss(net, decoder, schedule, batch, loss_ctx, weights, gen),
        model,
        opt,
        sched,
        settings,
        log,
        history,
        state,
        run_dir,
        ctx.is_main,
        after_step=lambda: ema.update(model),
    )
    steps_run = settings.steps - start
    return TrainResult(run_dir, final, history, steps_run / elapsed if elapsed > 0 else 0.0)


def main_from_file(path: str | Path, resume: bool) -> TrainResult:
    return train_denoiser(load_config(path), resume=resume)
