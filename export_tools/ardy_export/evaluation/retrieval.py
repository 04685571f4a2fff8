"""A small contrastive text-motion retrieval model (TMR-like), the evaluator behind
R-precision and FID.

Motion side: a fixed window of ``canonical_motion`` frames (default 80 = 4 s at 20 fps;
shorter motion is padded and masked), normalized with the training data's statistics,
``patch_frames`` frames per token, a pre-norm transformer, masked mean pooling, a linear
layer, L2 normalization. Text side: an MLP over the 384-d MiniLM sentence embedding (the
label bank's; the evaluator never runs MiniLM), L2 normalized to the same size.

Training: symmetric InfoNCE with a fixed temperature on random window crops of the train
split's clips (labels drawn uniformly, then a clip of the label weighted by its length), each
paired with a random one of its label's bank sentences; pairs of the same label are masked
out of each other's negatives (TMR). No mirror augmentation: left and right matter to the
labels. Progress: the averaged loss and the test clips' retrieval accuracy (centre window vs
the test labels, each label the mean of its sentences' text embeddings) every ``log_every``
steps; ``runs/evaluator/{latest,final}.pt`` checkpoints, ``--resume`` continues latest.pt.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Hashable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from ardy_export.evaluation.metrics import r_precision
from ardy_export.evaluation.motion_repr import (
    canonical_motion,
    canonical_size,
    centre_start,
    crop_windows,
)

DEFAULT_CONFIG_PATH = Path(__file__).resolve().parents[2] / "configs" / "evaluator.yaml"
TEXT_SIZE = 384
CHECKPOINT_KIND = "evaluator"
Log = Callable[[str], None]


# ---------------------------------------------------------------------------------------------
# Model


@dataclass(frozen=True)
class EvaluatorConfig:
    """Model and representation settings (the config's ``motion`` and ``model`` sections)."""

    window_frames: int = 80
    patch_frames: int = 2
    facing_smoothing_s: float = 0.1
    std_floor: float = 0.01
    width: int = 128
    layers: int = 3
    heads: int = 4
    ff_mult: int = 2
    dropout: float = 0.1
    text_hidden: int = 512
    dim: int = 256
    temperature: float = 0.07

    @classmethod
    def from_run_config(cls, config: Mapping[str, Any]) -> EvaluatorConfig:
        values = {**config.get("motion", {}), **config.get("model", {})}
        unknown = set(values) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"evaluator config: unknown motion/model keys {sorted(unknown)}")
        cfg = cls(**values)
        if cfg.window_frames % cfg.patch_frames:
            raise ValueError("evaluator config: window_frames must be a multiple of patch_frames")
        return cfg

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


class MotionEncoder(nn.Module):
    """Windows [B, W, D] + masks [B, W] (True = real frame) -> unit vectors [B, dim]."""

    def __init__(self, input_size: int, cfg: EvaluatorConfig) -> None:
        super().__init__()
        self.patch = cfg.patch_frames
        self.register_buffer("mean", torch.zeros(input_size))
        self.register_buffer("std", torch.ones(input_size))
        self.inp = nn.Linear(input_size * cfg.patch_frames, cfg.width)
        self.pos = nn.Parameter(
            torch.randn(cfg.window_frames // cfg.patch_frames, cfg.width) * 0.02
        )
        layer = nn.TransformerEncoderLayer(
            cfg.width,
            cfg.heads,
            cfg.ff_mult * cfg.width,
            cfg.dropout,
            activation="gelu",
            batch_first=True,
            norm_first=True,
        )
        self.encoder = nn.TransformerEncoder(layer, cfg.layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(cfg.width)
        self.out = nn.Linear(cfg.width, cfg.dim)

    def forward(self, windows: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        b, w, d = windows.shape
        x = (windows - self.mean) / self.std * mask[..., None]
        x = x.reshape(b, w // self.patch, self.patch * d)
        tokens = mask.reshape(b, w // self.patch, self.patch).any(-1)
        h = self.encoder(self.inp(x) + self.pos, src_key_padding_mask=~tokens)
        weights = tokens[..., None].to(h.dtype)
        pooled = (self.norm(h) * weights).sum(1) / weights.sum(1).clamp_min(1.0)
        return F.normalize(self.out(pooled), dim=-1)


class RetrievalModel(nn.Module):
    def __init__(self, input_size: int, cfg: EvaluatorConfig) -> None:
        super().__init__()
        self.motion = MotionEncoder(input_size, cfg)
        self.text = nn.Sequential(
            nn.Linear(TEXT_SIZE, cfg.text_hidden),
            nn.GELU(),
            nn.Dropout(cfg.dropout),
            nn.Linear(cfg.text_hidden, cfg.dim),
        )
        self.temperature = cfg.temperature

    def embed_text(self, embeddings: torch.Tensor) -> torch.Tensor:
        return F.normalize(self.text(embeddings), dim=-1)


def contrastive_loss(
    motion: torch.Tensor, text: torch.Tensor, labels: torch.Tensor, temperature: float
) -> torch.Tensor:
    """Symmetric InfoNCE over a batch of pairs; other pairs of the same label are no
    negatives (their logits are masked out)."""
    logits = motion @ text.T / temperature
    same = labels[:, None] == labels[None, :]
    same.fill_diagonal_(False)
    logits = logits.masked_fill(same, float("-inf"))
    target = torch.arange(len(labels), device=logits.device)
    return 0.5 * (F.cross_entropy(logits, target) + F.cross_entropy(logits.T, target))


# ---------------------------------------------------------------------------------------------
# Data


@dataclass
class RetrievalData:
    """Canonical frames per clip with integer labels; ``label_text[k]`` holds the [n, 384]
    sentence embeddings of label ``label_names[k]``."""

    train_frames: list[np.ndarray]
    train_labels: np.ndarray
    test_frames: list[np.ndarray]
    test_labels: np.ndarray
    label_text: list[np.ndarray]
    label_names: list[Hashable]
    joint_names: tuple[str, ...]
    fps: float


def build_retrieval_data(
    train: Sequence[tuple[np.ndarray, Hashable]],
    test: Sequence[tuple[np.ndarray, Hashable]],
    bank: Mapping[Hashable, np.ndarray],
    joint_names: Sequence[str],
    fps: float,
    cfg: EvaluatorConfig,
) -> RetrievalData:
    """``train`` / ``test``: (world positions [T, J, 3], label) pairs; ``bank``: label ->
    sentence embeddings [n, 384]."""
    names = sorted({label for _, label in [*train, *test]}, key=str)
    missing = [n for n in names if n not in bank]
    if missing:
        raise KeyError(f"labels without bank sentences: {missing[:5]} ({len(missing)} in all)")
    ids = {name: k for k, name in enumerate(names)}

    def frames(pairs: Sequence[tuple[np.ndarray, Hashable]]) -> list[np.ndarray]:
        return [canonical_motion(p, joint_names, fps, cfg.facing_smoothing_s) for p, _ in pairs]

    return RetrievalData(
        frames(train),
        np.array([ids[label] for _, label in train], np.int64),
        frames(test),
        np.array([ids[label] for _, label in test], np.int64),
        [np.asarray(bank[name], np.float32) for name in names],
        names,
        tuple(joint_names),
        float(fps),
    )


def load_retrieval_data(config: Mapping[str, Any], cfg: EvaluatorConfig) -> RetrievalData:
    """The processed dataset's train and test clips with the label bank's sentences."""
    from ardy_export.data.config import load_data_config
    from ardy_export.data.dataset import load_clips
    from ardy_export.data.features import positions_from_features
    from ardy_export.data.skeleton import JOINT_NAMES
    from ardy_export.text.encoder import load_label_bank

    data_cfg = config.get("data", {})
    clips_dir = Path(data_cfg.get("clips_dir", "data/processed"))
    bank = load_label_bank(Path(data_cfg.get("bank", "runs/text/bank.npz")))
    split = {
        name: [(positions_from_features(c.features), c.group) for c in load_clips(clips_dir, name)]
        for name in ("train", "test")
    }
    return build_retrieval_data(
        split["train"], split["test"], bank, JOINT_NAMES, load_data_config().fps, cfg
    )


def normalization_stats(
    frames: Sequence[np.ndarray], floor: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-feature mean and std (at least ``floor``) over all frames."""
    stacked = np.concatenate(frames).astype(np.float64)
    return stacked.mean(0).astype(np.float32), np.maximum(stacked.std(0), floor).astype(np.float32)


def sample_batch(
    data: RetrievalData, rng: np.random.Generator, batch: int, window: int
) -> dict[str, torch.Tensor]:
    """A uniformly drawn label per pair, a clip of it weighted by length, a random window
    crop, and a random one of the label's sentences."""
    labels_present = np.unique(data.train_labels)
    windows, masks, texts = [], [], []
    labels = rng.choice(labels_present, batch)
    for label in labels:
        members = np.flatnonzero(data.train_labels == label)
        lengths = np.array([len(data.train_frames[m]) for m in members], np.float64)
        clip = data.train_frames[int(rng.choice(members, p=lengths / lengths.sum()))]
        start = int(rng.integers(max(1, len(clip) - window + 1)))
        w, m = crop_windows(clip, [start], window)
        windows.append(w[0])
        masks.append(m[0])
        sentences = data.label_text[label]
        texts.append(sentences[rng.integers(len(sentences))])
    return {
        "windows": torch.from_numpy(np.stack(windows)),
        "mask": torch.from_numpy(np.stack(masks)),
        "text": torch.from_numpy(np.stack(texts)),
        "labels": torch.from_numpy(labels.astype(np.int64)),
    }


# ---------------------------------------------------------------------------------------------
# The evaluator (inference)


class Evaluator:
    """A trained retrieval model: motion windows and text embeddings -> unit vectors [N, dim].

    Motion is world joint positions [T, J, 3] in ``joint_names`` order at ``fps``.
    ``embed_motion`` embeds each motion's centre window (the whole motion, padded, when it is
    shorter than the window); ``embed_motion_windows`` embeds chosen windows of one motion.
    """

    def __init__(
        self,
        model: RetrievalModel,
        cfg: EvaluatorConfig,
        joint_names: Sequence[str],
        fps: float,
        batch_size: int = 256,
    ) -> None:
        self.model = model.eval()
        self.cfg = cfg
        self.joint_names = tuple(joint_names)
        self.fps = float(fps)
        self.batch_size = batch_size

    @property
    def dim(self) -> int:
        return self.cfg.dim

    @classmethod
    def load(cls, path: str | Path) -> Evaluator:
        ckpt = torch.load(Path(path), map_location="cpu", weights_only=False)
        if ckpt.get("kind") != CHECKPOINT_KIND:
            raise ValueError(f"{path}: not an evaluator checkpoint (kind {ckpt.get('kind')!r})")
        cfg = EvaluatorConfig(**ckpt["config"])
        model = RetrievalModel(canonical_size(len(ckpt["joint_names"])), cfg)
        model.load_state_dict(ckpt["model"])
        return cls(model, cfg, ckpt["joint_names"], ckpt["fps"])

    def save(self, path: str | Path) -> None:
        """An inference-only checkpoint (no optimizer state) that ``load`` reads."""
        from ardy_export.training.common import save_checkpoint

        save_checkpoint(Path(path), self.state())

    def state(self) -> dict[str, Any]:
        return {
            "kind": CHECKPOINT_KIND,
            "model": self.model.state_dict(),
            "config": self.cfg.to_dict(),
            "joint_names": list(self.joint_names),
            "fps": self.fps,
        }

    def canonical(self, positions: np.ndarray) -> np.ndarray:
        return canonical_motion(positions, self.joint_names, self.fps, self.cfg.facing_smoothing_s)

    @torch.inference_mode()
    def embed_windows(self, windows: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """Canonical windows [N, W, D] with masks [N, W] -> [N, dim]."""
        out = [
            self.model.motion(
                torch.from_numpy(windows[i : i + self.batch_size]),
                torch.from_numpy(mask[i : i + self.batch_size]),
            )
            for i in range(0, len(windows), self.batch_size)
        ]
        return torch.cat(out).numpy() if out else np.zeros((0, self.dim), np.float32)

    def embed_canonical(self, motions: Sequence[np.ndarray]) -> np.ndarray:
        """Centre windows of canonical motions [T, D] -> [N, dim]."""
        window = self.cfg.window_frames
        pieces = [crop_windows(m, [centre_start(len(m), window)], window) for m in motions]
        if not pieces:
            return np.zeros((0, self.dim), np.float32)
        return self.embed_windows(
            np.concatenate([w for w, _ in pieces]), np.concatenate([m for _, m in pieces])
        )

    def embed_motion(self, motions: Sequence[np.ndarray]) -> np.ndarray:
        """World positions [T, J, 3] per motion -> [N, dim] (each motion's centre window)."""
        return self.embed_canonical([self.canonical(p) for p in motions])

    def embed_motion_windows(
        self, positions: np.ndarray, window_starts: Sequence[int] | np.ndarray
    ) -> np.ndarray:
        """One motion's windows starting at ``window_starts`` (frames) -> [len(starts), dim];
        windows running past the end are padded and masked."""
        windows, mask = crop_windows(
            self.canonical(positions), window_starts, self.cfg.window_frames
        )
        return self.embed_windows(windows, mask)

    @torch.inference_mode()
    def embed_text(self, embeddings: np.ndarray) -> np.ndarray:
        """MiniLM sentence embeddings [N, 384] -> [N, dim]."""
        x = torch.from_numpy(np.asarray(embeddings, np.float32).reshape(-1, TEXT_SIZE))
        return self.model.embed_text(x).numpy()

    def label_prototypes(self, label_text: Sequence[np.ndarray]) -> np.ndarray:
        """One unit vector per label [L, dim]: the mean of its sentences' text embeddings."""
        means = np.stack([self.embed_text(t).mean(0) for t in label_text])
        return means / np.linalg.norm(means, axis=-1, keepdims=True)


def retrieval_accuracy(
    evaluator: Evaluator,
    frames: Sequence[np.ndarray],
    labels: np.ndarray,
    label_text: Sequence[np.ndarray],
    ks: Sequence[int] = (1, 3),
) -> dict[str, float]:
    """Top-k accuracy of ranking the labels present in ``labels`` for each motion (canonical
    frames, centre window) by similarity to the label prototypes."""
    candidates = np.unique(labels)
    protos = evaluator.label_prototypes([label_text[k] for k in candidates])
    scores = evaluator.embed_canonical(frames) @ protos.T
    own = scores[np.arange(len(labels)), np.searchsorted(candidates, labels)]
    rank = (scores > own[:, None]).sum(1)
    return {f"top{k}": float((rank < k).mean()) for k in ks}


def r_precision_on_test(
    evaluator: Evaluator, data: RetrievalData, seed: int, top_k: int = 3, pool: int = 32
) -> float:
    """R-precision of the test clips (centre windows) against a random sentence of each
    clip's label; the pool shrinks to the number of test labels when there are fewer."""
    rng = np.random.default_rng(seed)
    sentences = np.stack(
        [data.label_text[k][rng.integers(len(data.label_text[k]))] for k in data.test_labels]
    )
    pool = min(pool, len(np.unique(data.test_labels)))
    return r_precision(
        evaluator.embed_canonical(data.test_frames),
        evaluator.embed_text(sentences),
        top_k=min(top_k, pool),
        pool=pool,
        seed=seed,
        label_ids=data.test_labels,
    )


# ---------------------------------------------------------------------------------------------
# Training


class _Progress:
    """The step iterator handed to ``run_training_steps``: at each logged step (its
    ``set_postfix`` call) adds the test retrieval accuracy to the history row and prints it."""

    def __init__(
        self,
        start: int,
        steps: int,
        history: list[dict[str, float]],
        evaluate: Callable[[], dict[str, float]],
        log: Log,
    ) -> None:
        self.steps = range(start, steps)
        self.history = history
        self.evaluate = evaluate
        self.log = log

    def __iter__(self) -> Iterator[int]:
        return iter(self.steps)

    def set_postfix(self, _: object) -> None:
        row = self.history[-1]
        row.update(self.evaluate())
        self.log(
            f"step {int(row['step'])}/{self.steps.stop}: loss {row['loss']:.4f}, "
            f"test top-1 {row['top1']:.3f}, top-3 {row['top3']:.3f}, lr {row['lr']:.2e}"
        )


def train_evaluator(
    config: dict[str, Any],
    log: Log = print,
    resume: bool = False,
    data: RetrievalData | None = None,
) -> Path:
    """Train from a run config (configs/evaluator.yaml); returns the final checkpoint's path.

    ``data`` replaces the processed dataset (tests use synthetic motion). With ``resume`` the
    run continues from ``run_dir/latest.pt`` when it exists.
    """
    from ardy_export.training.common import (
        MetricsLog,
        Prefetcher,
        TrainSettings,
        make_optimizer,
        restore_rng,
        rng_state,
        run_training_steps,
        seed_everything,
    )

    cfg = EvaluatorConfig.from_run_config(config)
    settings = TrainSettings.from_dict(config.get("train", {}))
    seed = int(config.get("seed", 0))
    seed_everything(seed)
    if settings.threads:
        torch.set_num_threads(settings.threads)
    run_dir = Path(config.get("run_dir", "runs/evaluator"))
    latest = run_dir / "latest.pt"
    if data is None:
        data = load_retrieval_data(config, cfg)
    log(
        f"evaluator data: {len(data.train_frames)} train clips, {len(data.test_frames)} test "
        f"clips, {len(np.unique(data.test_labels))} test labels"
    )
    model = RetrievalModel(canonical_size(len(data.joint_names)), cfg)
    mean, std = normalization_stats(data.train_frames, cfg.std_floor)
    model.motion.mean.copy_(torch.from_numpy(mean))
    model.motion.std.copy_(torch.from_numpy(std))
    opt, sched = make_optimizer(model, settings)
    rng = np.random.default_rng(seed + 1)
    gen = torch.Generator().manual_seed(seed + 2)
    start = 0
    resumed_at: int | None = None
    if resume and latest.is_file():
        ckpt = torch.load(latest, map_location="cpu", weights_only=False)
        model.load_state_dict(ckpt["model"])
        opt.load_state_dict(ckpt["optimizer"])
        sched.load_state_dict(ckpt["scheduler"])
        restore_rng(ckpt["rng"], rng, gen)
        start = resumed_at = int(ckpt["step"])
        log(f"resuming {latest} at step {start}")
    evaluator = Evaluator(model, cfg, data.joint_names, data.fps)

    def evaluate() -> dict[str, float]:
        model.eval()
        scores = retrieval_accuracy(evaluator, data.test_frames, data.test_labels, data.label_text)
        model.train()
        return scores

    def state(step: int) -> dict[str, Any]:
        return {
            **evaluator.state(),
            "step": step,
            "run_config": {k: v for k, v in config.items() if not k.startswith("_")},
            "optimizer": opt.state_dict(),
            "scheduler": sched.state_dict(),
            "rng": rng_state(rng, gen),
        }

    def compute_loss(batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
        motion = model.motion(batch["windows"], batch["mask"])
        text = model.embed_text(batch["text"])
        loss = contrastive_loss(motion, text, batch["labels"], cfg.temperature)
        return loss, {"loss": float(loss.detach())}

    history: list[dict[str, float]] = []
    model.train()
    final, elapsed = run_training_steps(
        _Progress(start, settings.steps, history, evaluate, log),  # type: ignore[arg-type]
        Prefetcher(
            lambda: sample_batch(data, rng, settings.batch_size, cfg.window_frames),
            settings.prefetch,
        ),
        torch.device("cpu"),
        compute_loss,
        model,
        opt,
        sched,
        settings,
        MetricsLog(run_dir / "metrics.jsonl", True, resumed_at),
        history,
        state,
        run_dir,
        True,
    )
    model.eval()
    rp = r_precision_on_test(evaluator, data, seed)
    steps_run = settings.steps - start
    log(
        f"evaluator: {steps_run} steps in {elapsed:.0f} s; test R-precision top-3 "
        f"(pool {min(32, len(np.unique(data.test_labels)))}) {rp:.3f}; checkpoint {final}"
    )
    return final


# ---------------------------------------------------------------------------------------------
# Command line


def _train_command(args: argparse.Namespace) -> int:
    from ardy_export.training.common import load_config

    config = load_config(args.config)
    if args.run_dir:
        config["run_dir"] = args.run_dir
    for key in ("steps", "threads"):
        if getattr(args, key):
            config.setdefault("train", {})[key] = getattr(args, key)
    train_evaluator(config, resume=args.resume)
    return 0


def add_commands(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add ``train-evaluator`` to a subparsers object (e.g. the ``eval`` command group's)."""
    p = commands.add_parser(
        "train-evaluator",
        help="train the text-motion retrieval evaluator (R-precision, FID)",
        description="Contrastive text-motion retrieval model on the processed dataset's train "
        "split; prints the loss and the test clips' retrieval accuracy as it goes.",
    )
    p.add_argument("--config", default=str(DEFAULT_CONFIG_PATH), help="(default: %(default)s)")
    p.add_argument("--resume", action="store_true", help="continue from RUN_DIR/latest.pt")
    p.add_argument("--run-dir", help="override the config's run_dir")
    p.add_argument("--steps", type=int, help="override train.steps")
    p.add_argument("--threads", type=int, help="override train.threads (torch CPU threads)")
    p.set_defaults(handler=_train_command)
