"""Training batches: tokenizer crops and denoiser windows with history, future and goals."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from ardy_export.models import layout as L
from ardy_export.models.denoiser import DenoiserConfig
from ardy_export.training.adapters import LabelKey, TextBank, TrainSequence
from ardy_export.training.constraint_sampling import (
    ConstraintSamplingConfig,
    sample_constraint_mask,
)


def split_long(sequences: Sequence[TrainSequence], max_frames: int) -> list[TrainSequence]:
    """Cut sequences longer than ``max_frames`` into consecutive pieces (labels kept)."""
    out: list[TrainSequence] = []
    for seq in sequences:
        n = len(seq.features)
        if n <= max_frames:
            out.append(seq)
            continue
        for k, a in enumerate(range(0, n, max_frames)):
            b = min(n, a + max_frames)
            if b - a < max_frames // 4 and k > 0:
                break
            segs = [
                (max(s, a) - a, min(e, b) - a, key) for s, e, key in seq.segments if s < b and e > a
            ]
            out.append(TrainSequence(f"{seq.name}#{k}", seq.features[a:b], segs))
    return out


def recenter_xz(frames: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """Translation-only re-centering: subtract the anchor frame's x and z from p.x, p.z."""
    f = frames.copy()
    f[:, 0] -= anchor[0]
    f[:, 2] -= anchor[2]
    return f


def tokenizer_batch(
    sequences: Sequence[TrainSequence],
    rng: np.random.Generator,
    batch_size: int,
    tokens: int,
    patch: int,
    mean: np.ndarray,
    std: np.ndarray,
    yaw: bool = True,
) -> dict[str, Tensor]:
    """Random crops of ``tokens`` tokens (fewer if no sequence is that long): normalized
    body, root, previous root and raw frames."""
    longest = max(len(s.features) for s in sequences) // patch
    frames = min(tokens, longest) * patch
    usable = [s for s in sequences if len(s.features) >= frames]
    if not usable:
        raise ValueError(f"no sequence has {frames} frames for a tokenizer crop")
    # Gather frames+1 frames per sample (the frame before the crop first; a crop at frame 0
    # repeats its first frame there and is marked as having no previous frame), rotate,
    # re-center on that first frame and normalize, all batched.
    chunks = np.empty((batch_size, frames + 1, L.FEATURE_SIZE), np.float32)
    valid = np.zeros(batch_size, np.float32)
    for i in range(batch_size):
        seq = usable[int(rng.integers(0, len(usable)))]
        start = int(rng.integers(0, len(seq.features) - frames + 1))
        if start > 0:
            chunks[i] = seq.features[start - 1 : start + frames]
            valid[i] = 1.0
        else:
            chunks[i, 0] = seq.features[0]
            chunks[i, 1:] = seq.features[:frames]
    if yaw:
        chunks = rotate_yaw_batch(chunks, rng.uniform(-np.pi, np.pi, size=batch_size))
    chunks[..., 0] -= chunks[:, :1, 0]
    chunks[..., 2] -= chunks[:, :1, 2]
    norm = (chunks - mean) / std
    prev = norm[:, 0, L.ROOT_SLICE] * valid[:, None]
    return {
        "body": torch.from_numpy(np.ascontiguousarray(norm[:, 1:, L.BODY_SLICE], np.float32)),
        "root": torch.from_numpy(np.ascontiguousarray(norm[:, 1:, L.ROOT_SLICE], np.float32)),
        "prev_root": torch.from_numpy(prev.astype(np.float32)),
        "prev_valid": torch.from_numpy(valid),
        "raw": torch.from_numpy(np.ascontiguousarray(chunks[:, 1:], np.float32)),
    }


def rotate_yaw_batch(features: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotate world features [B, T, M] about +Y through the origin by per-row ``angles`` [B]
    (the same maths as the data package's ``rotate_yaw``, batched, float32): every 3-vector
    (position, 6D column, joint position, velocity) gets ``x' = c x + s z``,
    ``z' = -s x + c z``; the heading angle grows by the angle."""
    c = np.cos(angles).astype(np.float32)[:, None, None]
    s = np.sin(angles).astype(np.float32)[:, None, None]
    b, t, _ = features.shape
    f = features.astype(np.float32, copy=True)
    vectors = np.concatenate(
        (
            f[..., L.POS_SLICE],
            f[..., L.ROT6D_SLICE.start : L.JOINT_VEL_SLICE.stop],
        ),
        axis=-1,
    ).reshape(b, t, -1, 3)
    x = vectors[..., 0].copy()
    z = vectors[..., 2].copy()
    vectors[..., 0] = c * x + s * z
    vectors[..., 2] = c * z - s * x
    flat = vectors.reshape(b, t, -1)
    f[..., L.POS_SLICE] = flat[..., :3]
    f[..., L.ROT6D_SLICE.start : L.JOINT_VEL_SLICE.stop] = flat[..., 3:]
    ch, sh = f[..., 3].copy(), f[..., 4].copy()
    f[..., 3] = c[..., 0] * ch - s[..., 0] * sh
    f[..., 4] = s[..., 0] * ch + c[..., 0] * sh
    return f


@dataclass
class EncodedSequence:
    """A (yaw-rotated, maybe mirrored) sequence and its latent tokens."""

    features: np.ndarray  # [T, M] world, T a multiple of P
    latent: np.ndarray  # [T / P, L] normalized latent tokens
    segments: list[tuple[int, int, LabelKey]]

    def label_at(self, frame: int) -> LabelKey:
        for start, end, key in self.segments:
            if start <= frame < end:
                return key
        return self.segments[-1][2]


@dataclass
class WindowSamplingConfig:
    text_drop: float = 0.1
    constraint_drop: float = 0.1
    p_full_history: float = 0.5
    # Exponent a of the content-balanced draw (``sequence_weights``): 0 draws every
    # sequence alike, 1 every (dataset, content) alike.
    content_balance: float = 0.0
    # Share of each batch drawn content-balanced as text-only windows (no goals); the rest is
    # drawn alike with the constraint patterns. 0: every window drawn by content_balance.
    # Why: balancing every window raised R-precision but moved the windows that teach the
    # goals off the plain draw, and the model-only waypoints went over their bar with it
    # (docs/evaluation, stages 14 to 35); this balances only the text.
    balanced_text_share: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.balanced_text_share <= 1.0:
            raise ValueError(
                f"data.balanced_text_share is {self.balanced_text_share}, expected 0 to 1"
            )
        if self.balanced_text_share and not self.content_balance:
            raise ValueError(
                "data.balanced_text_share needs data.content_balance > 0 (the balanced draw's "
                "exponent)"
            )


def sequence_weights(
    segments: Sequence[Sequence[tuple[int, int, LabelKey]]], exponent: float
) -> np.ndarray:
    """Probabilities of drawing each sequence (given by its labelled segments) for a window.

    A single-label sequence weighs ``n ** -exponent``, ``n`` the number of single-label
    sequences of its (dataset, content): the data holds 13 bows against 317 raised left
    hands, and with every sequence alike the model saw a bow in 1 window of 200. Sequences
    of several labels (stitched transitions) keep their share of the draw."""
    single = [len(segs) == 1 for segs in segments]
    contents = [segs[0][2][:2] if one else None for segs, one in zip(segments, single, strict=True)]
    counts: dict[object, int] = {}
    for content in contents:
        if content is not None:
            counts[content] = counts.get(content, 0) + 1
    weights = np.array(
        [1.0 if c is None else float(counts[c]) ** -exponent for c in contents], np.float64
    )
    plain = np.array(single)
    if plain.any():
        # Single-label sequences together keep the share they have when drawn alike.
        weights[plain] *= plain.sum() / weights[plain].sum()
    return weights / weights.sum()


def _tokens_from_frames(frames: np.ndarray, latent: np.ndarray, patch: int) -> np.ndarray:
    """Normalized frames [n*P, M] + latent [n, L] -> hybrid tokens [n, 5P + L]."""
    n = latent.shape[0]
    root = frames[:, L.ROOT_SLICE].reshape(n, patch * 5)
    return np.concatenate((root, latent), axis=1)


def denoiser_batch(
    encoded: Sequence[EncodedSequence],
    rng: np.random.Generator,
    batch_size: int,
    cfg: DenoiserConfig,
    mean: np.ndarray,
    std: np.ndarray,
    text_bank: TextBank,
    constraints: ConstraintSamplingConfig,
    windows: WindowSamplingConfig,
) -> dict[str, Tensor]:
    """A batch of training windows (inputs of Denoiser.forward plus targets)."""
    p, c = cfg.patch, cfg.window_tokens
    usable = [e for e in encoded if e.latent.shape[0] >= c]
    if not usable:
        raise ValueError(f"no encoded sequence has the {c} tokens of a window")
    # Drawn up front when balanced; one draw per window otherwise (as runs before had it).
    # With a balanced text share, the first windows of the batch are the balanced ones.
    text_only = windows.balanced_text_share > 0.0
    if text_only:
        balanced = round(windows.balanced_text_share * batch_size)
    else:
        balanced = batch_size if windows.content_balance else 0
    picks = (
        rng.choice(
            len(usable),
            size=balanced,
            p=sequence_weights([e.segments for e in usable], windows.content_balance),
        )
        if balanced
        else None
    )
    samples = []
    for i in range(batch_size):
        from_balanced = i < balanced
        e = usable[int(picks[i]) if from_balanced else int(rng.integers(0, len(usable)))]
        t_tok = e.latent.shape[0]
        s = int(rng.integers(0, t_tok - c + 1))
        h_avail = min(s, cfg.max_history_tokens)
        h = h_avail if rng.random() < windows.p_full_history else int(rng.integers(0, h_avail + 1))
        f_avail = min(t_tok - s - c, cfg.max_future_tokens)
        anchor = e.features[s * p - 1] if h > 0 else e.features[s * p]
        lo, hi = (s - h) * p, (s + c + f_avail) * p
        frames = (recenter_xz(e.features[lo:hi], anchor) - mean) / std
        tokens = _tokens_from_frames(frames, e.latent[s - h : s + c + f_avail], p)
        wf = frames[h * p :]  # window + future frames
        mask = (
            np.zeros(((c + f_avail) * p, L.FEATURE_SIZE), np.float32)
            if from_balanced and text_only
            else sample_constraint_mask(c * p, f_avail * p, rng, constraints)
        )
        goal = (wf * mask).reshape(c + f_avail, p * L.FEATURE_SIZE)
        mask_t = mask.reshape(c + f_avail, p * L.FEATURE_SIZE)
        fut_any = mask_t[c:].any(axis=1)
        f_used = int(np.nonzero(fut_any)[0][-1]) + 1 if fut_any.any() else 0
        samples.append(
            {
                "x0": tokens[h : h + c],
                "history": tokens[:h],
                "window_goal": goal[:c],
                "window_goal_mask": mask_t[:c],
                "future_goal": goal[c : c + f_used],
                "future_goal_mask": mask_t[c : c + f_used],
                "future_mask": fut_any[:f_used].astype(np.float32),
                "body": wf[: c * p, L.BODY_SLICE],
                "prev_root": frames[h * p - 1, L.ROOT_SLICE] if h > 0 else np.zeros(5),
                "prev_valid": 1.0 if h > 0 else 0.0,
                "text": text_bank.sample(e.label_at(s * p), rng),
                "text_keep": 0.0 if rng.random() < windows.text_drop else 1.0,
                "constraint_keep": 0.0 if rng.random() < windows.constraint_drop else 1.0,
            }
        )
    return collate_windows(samples, cfg)


def collate_windows(samples: list[dict[str, object]], cfg: DenoiserConfig) -> dict[str, Tensor]:
    """Pad histories at the front and futures at the back; stack everything as float32."""
    b = len(samples)
    h_max = max(len(s["history"]) for s in samples)  # type: ignore[arg-type]
    f_max = max(len(s["future_mask"]) for s in samples)  # type: ignore[arg-type]
    d, gd = cfg.token_dim, cfg.goal_dim
    hist = np.zeros((b, h_max, d), np.float32)
    hmask = np.zeros((b, h_max), np.float32)
    fgoal = np.zeros((b, f_max, gd), np.float32)
    fgmask = np.zeros((b, f_max, gd), np.float32)
    fmask = np.zeros((b, f_max), np.float32)
    for i, s in enumerate(samples):
        h = len(s["history"])  # type: ignore[arg-type]
        f = len(s["future_mask"])  # type: ignore[arg-type]
        if h:
            hist[i, h_max - h :] = s["history"]
            hmask[i, h_max - h :] = 1.0
        if f:
            fgoal[i, :f] = s["future_goal"]
            fgmask[i, :f] = s["future_goal_mask"]
            fmask[i, :f] = s["future_mask"]

    def stack(key: str) -> Tensor:
        return torch.from_numpy(np.stack([np.asarray(s[key], np.float32) for s in samples]))

    return {
        "x0": stack("x0"),
        "history": torch.from_numpy(hist),
        "history_mask": torch.from_numpy(hmask),
        "window_goal": stack("window_goal"),
        "window_goal_mask": stack("window_goal_mask"),
        "future_goal": torch.from_numpy(fgoal),
        "future_goal_mask": torch.from_numpy(fgmask),
        "future_mask": torch.from_numpy(fmask),
        "body": stack("body"),
        "prev_root": stack("prev_root"),
        "prev_valid": torch.tensor([float(s["prev_valid"]) for s in samples]),  # type: ignore[arg-type]
        "text_embedding": stack("text"),
        "text_keep": torch.tensor([float(s["text_keep"]) for s in samples]),  # type: ignore[arg-type]
        "constraint_keep": torch.tensor([float(s["constraint_keep"]) for s in samples]),  # type: ignore[arg-type]
    }
