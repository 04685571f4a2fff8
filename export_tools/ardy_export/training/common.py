"""Shared training machinery: run configs, devices and DDP, schedules, EMA, checkpoints, logs."""

from __future__ import annotations

import copy
import json
import math
import os
import queue
import random
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import torch
import torch.distributed as dist
import yaml
from torch import nn


def load_config(path: str | Path) -> dict[str, Any]:
    """A run config (YAML mapping)."""
    p = Path(path)
    with p.open(encoding="utf-8") as handle:
        raw = yaml.safe_load(handle) or {}
    if not isinstance(raw, dict):
        raise ValueError(f"{p}: a run config must be a mapping at the top level")
    raw.setdefault("_config_path", str(p.resolve()))
    return raw


def resolve_path(value: str | Path, config: dict[str, Any]) -> Path:
    """Relative paths in a config are relative to the current directory (the repo root when
    the commands are run from it, as the README does)."""
    del config
    return Path(value).expanduser()


T = TypeVar("T")


@dataclass
class TrainSettings:
    steps: int = 1000
    batch_size: int = 32
    lr: float = 3e-4
    weight_decay: float = 0.01
    beta1: float = 0.9
    beta2: float = 0.99
    warmup_steps: int = 100
    min_lr_ratio: float = 0.1
    grad_clip: float = 1.0
    checkpoint_every: int = 500
    keep_every: int = 0  # also keep ckpt_<step>.pt every this many steps (0: only latest)
    log_every: int = 10
    ema_decay: float = 0.999
    threads: int = 0  # torch intra-op threads on the CPU (0: torch's default)
    prefetch: int = 0  # batches built ahead on a background thread (0: none; GPU runs: 2-4)
    extra: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> TrainSettings:
        known = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        extra = {k: v for k, v in values.items() if k not in cls.__dataclass_fields__}
        settings = cls(**known)
        settings.extra = extra
        return settings


@dataclass
class RunContext:
    device: torch.device
    rank: int = 0
    world_size: int = 1
    distributed: bool = False

    @property
    def is_main(self) -> bool:
        return self.rank == 0


def setup_run(device: str = "auto") -> RunContext:
    """CPU by default, CUDA when present (or asked), DDP when launched by torchrun."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if device == "auto":
        device = "cuda" if torch.cuda.is_available() else "cpu"
    if device == "cuda" and not torch.cuda.is_available():
        raise RuntimeError("device: cuda was asked for but no CUDA device is available")
    if world > 1:
        rank = int(os.environ["RANK"])
        local = int(os.environ.get("LOCAL_RANK", "0"))
        backend = "nccl" if device == "cuda" else "gloo"
        if not dist.is_initialized():
            dist.init_process_group(backend=backend)
        dev = torch.device(f"cuda:{local}") if device == "cuda" else torch.device("cpu")
        if device == "cuda":
            torch.cuda.set_device(dev)
        return RunContext(dev, rank, world, True)
    return RunContext(torch.device("cuda" if device == "cuda" else "cpu"))


def teardown_run(ctx: RunContext) -> None:
    if ctx.distributed and dist.is_initialized():
        dist.destroy_process_group()


def run_in_context(
    train: Callable[[dict[str, Any], TrainSettings, RunContext, bool, bool], T],
    config: dict[str, Any],
    resume: bool,
    progress: bool,
) -> T:
    """Runs a trainer's ``train(config, settings, ctx, resume, progress)`` inside its run
    context (device, DDP), torn down afterwards."""
    settings = TrainSettings.from_dict(config.get("train", {}))
    ctx = setup_run(str(config.get("device", "auto")))
    try:
        return train(config, settings, ctx, resume, progress)
    finally:
        teardown_run(ctx)


def begin_run(
    config: dict[str, Any], settings: TrainSettings, ctx: RunContext, default_run_dir: str
) -> tuple[int, Path]:
    """Seeds every generator, sets the CPU threads; returns (seed, run folder)."""
    seed = int(config.get("seed", 0))
    seed_everything(seed + ctx.rank)
    if settings.threads:
        torch.set_num_threads(settings.threads)
    return seed, Path(config.get("run_dir", default_run_dir))


def seed_everything(seed: int) -> None:
    random.seed(seed)
    np.random.seed(seed)  # noqa: NPY002 - libraries that use the global state
    torch.manual_seed(seed)


def warmup_cosine(step: int, settings: TrainSettings) -> float:
    """LR multiplier: linear warm-up, then cosine from 1 to ``min_lr_ratio``."""
    if step < settings.warmup_steps:
        return (step + 1) / max(1, settings.warmup_steps)
    span = max(1, settings.steps - settings.warmup_steps)
    progress = min(1.0, (step - settings.warmup_steps) / span)
    return settings.min_lr_ratio + (1.0 - settings.min_lr_ratio) * 0.5 * (
        1.0 + math.cos(math.pi * progress)
    )


def make_optimizer(
    model: nn.Module, settings: TrainSettings
) -> tuple[torch.optim.Optimizer, torch.optim.lr_scheduler.LambdaLR]:
    """AdamW with weight decay on matrices only, under the warmup-cosine schedule.
    ``train.lr_scale`` ({name part: factor}) trains the parameters whose names contain a
    part at that multiple of the learning rate (the first part that matches), e.g. a part
    just added to a trained model so that it catches up within a short run."""
    scales = {
        str(part): float(factor) for part, factor in settings.extra.get("lr_scale", {}).items()
    }
    groups: dict[tuple[bool, float], list[nn.Parameter]] = {}
    used: set[str] = set()
    for name, param in model.named_parameters():
        if not param.requires_grad:
            continue
        part = next((part for part in scales if part in name), None)
        if part is not None:
            used.add(part)
        decays = not (param.dim() < 2 or "embedding" in name)
        groups.setdefault((decays, scales[part] if part else 1.0), []).append(param)
    unknown = sorted(set(scales) - used)
    if unknown:
        raise ValueError(f"train.lr_scale: no trainable parameter's name contains {unknown[0]!r}")
    opt = torch.optim.AdamW(
        [
            {
                "params": params,
                "weight_decay": settings.weight_decay if decays else 0.0,
                "lr": settings.lr * scale,
            }
            # Decayed first, then by scale: without lr_scale, the two groups of earlier runs.
            for (decays, scale), params in sorted(
                groups.items(), key=lambda g: (not g[0][0], g[0][1])
            )
        ],
        lr=settings.lr,
        betas=(settings.beta1, settings.beta2),
    )
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda s: warmup_cosine(s, settings))
    return opt, sched


class EMA:
    """Exponential moving average of a model's parameters and buffers."""

    def __init__(self, model: nn.Module, decay: float) -> None:
        self.decay = decay
        self.model = copy.deepcopy(model).eval()
        for p in self.model.parameters():
            p.requires_grad_(False)
        self.updates = 0

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        self.updates += 1
        d = min(self.decay, (1.0 + self.updates) / (10.0 + self.updates))
        ema_params = list(self.model.parameters())
        params = [p.detach() for p in model.parameters()]
        torch._foreach_lerp_(ema_params, params, 1.0 - d)
        for ema_b, b in zip(self.model.buffers(), model.buffers(), strict=True):
            ema_b.copy_(b)

    def state_dict(self) -> dict[str, Any]:
        return self.model.state_dict()


def unwrap(model: nn.Module) -> nn.Module:
    return model.module if hasattr(model, "module") else model


def save_checkpoint(path: Path, state: dict[str, Any]) -> None:
    """Write atomically (temporary file, then rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.save(state, tmp)
    tmp.replace(path)


# What a slim denoiser checkpoint drops: training state only.
TRAINING_ONLY_KEYS = ("model", "optimizer", "scheduler", "rng")


def _load_denoiser_with_ema(path: Path) -> dict[str, Any]:
    ckpt = torch.load(path, map_location="cpu", weights_only=False)
    if ckpt.get("kind") != "denoiser" or ckpt.get("ema") is None:
        raise ValueError(f"{path}: not a denoiser checkpoint with EMA weights")
    return ckpt


def slim_checkpoint(path: Path, out: Path) -> Path:
    """Writes ``path`` without ``TRAINING_ONLY_KEYS`` to ``out`` (the EMA weights stay)."""
    ckpt = _load_denoiser_with_ema(path)
    save_checkpoint(out, {k: v for k, v in ckpt.items() if k not in TRAINING_ONLY_KEYS})
    return out


def blend_checkpoints(first: Path, second: Path, weight: float, out: Path) -> Path:
    """Writes ``second`` with every EMA weight ``(1 - weight) * first + weight * second``.

    Both must be slim-able denoiser checkpoints of one architecture over one tokenizer
    (fine-tunes of a common ancestor, where averaging weights trades their strengths: a
    model soup); anything else is refused before writing. ``blended_from`` records the pair.
    """
    if not 0.0 <= weight <= 1.0:
        raise ValueError(f"weight {weight} is outside [0, 1]")
    base, other = _load_denoiser_with_ema(first), _load_denoiser_with_ema(second)
    if base["denoiser_config"] != other["denoiser_config"]:
        raise ValueError(f"{second}: its denoiser config differs from {first}'s")
    if base["ema"].keys() != other["ema"].keys():
        raise ValueError(f"{second}: its weights are named differently from {first}'s")
    for key, value in base["tokenizer"].items():
        if not torch.equal(value, other["tokenizer"].get(key, torch.empty(0))):
            raise ValueError(f"{second}: tokenizer weight {key} differs from {first}'s")
    blended = {}
    for key, value in other["ema"].items():
        if value.shape != base["ema"][key].shape:
            raise ValueError(
                f"{second}: weight {key} is {tuple(value.shape)}, {first}'s "
                f"{tuple(base['ema'][key].shape)}"
            )
        blended[key] = (
            torch.lerp(base["ema"][key], value, weight) if value.is_floating_point() else value
        )
    result = {k: v for k, v in other.items() if k not in TRAINING_ONLY_KEYS}
    result["ema"] = blended
    result["blended_from"] = {"first": str(first), "second": str(second), "weight": weight}
    save_checkpoint(out, result)
    return out


def rng_state(rng: np.random.Generator, gen: torch.Generator) -> dict[str, Any]:
    return {
        "numpy": rng.bit_generator.state,
        "torch": gen.get_state(),
        "torch_global": torch.get_rng_state(),
    }


def restore_rng(state: dict[str, Any], rng: np.random.Generator, gen: torch.Generator) -> None:
    rng.bit_generator.state = state["numpy"]
    gen.set_state(state["torch"])
    torch.set_rng_state(state["torch_global"])


class MetricsLog:
    """Append-only JSONL of losses per logged step (``metrics.jsonl`` in the run folder).

    ``resumed_at``: the step of the checkpoint a run resumes from. Rows logged after it by the
    stopped run are dropped, since the resumed run logs those steps again, so the file keeps
    one row per step however often a run was stopped. ``time_s`` counts from each start.
    """

    def __init__(self, path: Path, enabled: bool, resumed_at: int | None = None) -> None:
        self.path = path
        self.enabled = enabled
        self.start = time.perf_counter()
        if not enabled:
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        if resumed_at is not None and path.is_file():
            lines = path.read_text(encoding="utf-8").splitlines()
            kept = [line for line in lines if json.loads(line)["step"] <= resumed_at]
            if len(kept) < len(lines):
                path.write_text("".join(line + "\n" for line in kept), encoding="utf-8")

    def write(self, step: int, values: dict[str, float]) -> None:
        if not self.enabled:
            return
        row = {"step": step, "time_s": round(time.perf_counter() - self.start, 3)}
        row.update({k: float(v) for k, v in values.items()})
        with self.path.open("a", encoding="utf-8") as handle:
            handle.write(json.dumps(row) + "\n")


def average_parts(rows: list[dict[str, float]]) -> dict[str, float]:
    keys = {k for r in rows for k in r}
    return {k: float(np.mean([r[k] for r in rows if k in r])) for k in sorted(keys)}


class Prefetcher:
    """Builds batches ahead on one background thread (numpy releases the GIL for most of the
    work), so a GPU step and the next batch overlap. ``depth = 0`` builds them inline.

    The batch order is the same as without prefetching; a checkpoint's RNG state is then
    ``depth`` batches ahead, so a resumed run draws different (equally random) batches.
    """

    def __init__(self, make: Callable[[], dict[str, Any]], depth: int) -> None:
        self.make = make
        self.depth = depth
        self.stop = threading.Event()
        self.queue: queue.Queue[Any] = queue.Queue(maxsize=max(1, depth))
        self.thread: threading.Thread | None = None
        if depth > 0:
            self.thread = threading.Thread(target=self._run, daemon=True)
            self.thread.start()

    def _run(self) -> None:
        try:
            while not self.stop.is_set():
                item = self.make()
                while not self.stop.is_set():
                    try:
                        self.queue.put(item, timeout=0.1)
                        break
                    except queue.Full:
                        continue
        except BaseException as error:  # handed to the consumer
            self.queue.put(error)

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return self

    def __next__(self) -> dict[str, Any]:
        if self.thread is None:
            return self.make()
        item = self.queue.get()
        if isinstance(item, BaseException):
            raise item
        return item

    def close(self) -> None:
        self.stop.set()
        if self.thread is not None:
            self.thread.join(timeout=5.0)


def run_training_steps(
    bar: Iterator[int],
    batches: Prefetcher,
    device: torch.device,
    compute_loss: Callable[[dict[str, torch.Tensor]], tuple[torch.Tensor, dict[str, float]]],
    model: nn.Module,
    opt: torch.optim.Optimizer,
    sched: torch.optim.lr_scheduler.LRScheduler,
    settings: TrainSettings,
    log: MetricsLog,
    history: list[dict[str, float]],
    state: Callable[[int], dict[str, Any]],
    run_dir: Path,
    is_main: bool,
    after_step: Callable[[], None] | None = None,
) -> tuple[Path, float]:
    """The optimization loop both trainers share: step, clip, log averaged losses, keep
    checkpoints, save ``final.pt``. Returns the final checkpoint and the seconds taken."""
    t0 = time.perf_counter()
    window: list[dict[str, float]] = []
    latest = run_dir / "latest.pt"
    for step in bar:
        batch = {k: v.to(device) for k, v in next(batches).items()}
        loss, parts = compute_loss(batch)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        if settings.grad_clip > 0:
            torch.nn.utils.clip_grad_norm_(model.parameters(), settings.grad_clip)
        opt.step()
        sched.step()
        if after_step is not None:
            after_step()
        window.append(parts)
        done = step + 1
        if done % settings.log_every == 0 or done == settings.steps:
            row = average_parts(window)
            row["lr"] = sched.get_last_lr()[0]
            window = []
            history.append({"step": float(done), **row})
            log.write(done, row)
            if hasattr(bar, "set_postfix"):
                bar.set_postfix({k: f"{v:.4f}" for k, v in row.items() if k != "lr"})
        if is_main and (done % settings.checkpoint_every == 0 or done == settings.steps):
            save_checkpoint(latest, state(done))
            if settings.keep_every and done % settings.keep_every == 0:
                save_checkpoint(run_dir / f"ckpt_{done:08d}.pt", state(done))
    batches.close()
    elapsed = time.perf_counter() - t0
    final = run_dir / "final.pt"
    if is_main:
        save_checkpoint(final, state(settings.steps))
    return final, elapsed
