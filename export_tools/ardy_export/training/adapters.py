"""The few places where training touches the data (part A) and text (part B) packages.

Data: ``ardy_export.data`` (``dataset.load_clips``, ``dataset.clips_from_bvh_files``,
``augment.rotate_yaw`` / ``mirror_clip``, ``normalization.compute_normalization_stats``,
``stitching.build_stitched_sequences``, ``skeleton.default_skeleton``). Text:
``ardy_export.text`` (``sentences_for``, ``canonical_prompt``) and
``ardy_export.text.encoder`` (``TextEncoder``, ``load_embedding_cache``).

Each function falls back to a self-contained version (synthetic clips, hashed
pseudo-embeddings) when asked for (``source: synthetic``, ``text.mode: hashed``) or when the
package is absent, so the models and trainers can be tested without the BVH data or the
sentence encoder.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ardy_export.models import layout as L
from ardy_export.models.layout import Skeleton
from ardy_export.training import synthetic

TEXT_DIM = 384
LabelKey = tuple[str, str, str]  # (dataset, content, style)


@dataclass
class TrainSequence:
    """One training sequence: world features and the label of every frame range."""

    name: str
    features: np.ndarray  # [T, M] float32, world space
    segments: list[tuple[int, int, LabelKey]] = field(default_factory=list)  # [start, end)

    def label_at(self, frame: int) -> LabelKey:
        for start, end, key in self.segments:
            if start <= frame < end:
                return key
        return self.segments[-1][2]


# ----------------------------------------------------------------------------- data


def data_package_available() -> bool:
    try:
        from ardy_export.data import dataset  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass
class _ClipLike:
    """What the data package's Clip offers and the synthetic fallback imitates."""

    name: str
    dataset: str
    content: str
    style: str
    features: np.ndarray
    split: str = "train"


def load_clips(cfg: dict[str, Any]) -> list[Any]:
    """Clips of the data section of a run config.

    ``source: synthetic``: ``synthetic_clips`` generated clips (``synthetic_seed``).
    ``source: processed``: ``load_clips(clips_dir, split)`` of a prepared dataset.
    ``source: bvh``: ``clips_from_bvh_files(bvh_files)`` (a handful of BVH files).
    Then ``clip_names`` / ``max_clips`` filter.
    """
    source = str(cfg.get("source", "synthetic"))
    clips: list[Any]
    if source == "synthetic":
        raw = synthetic.synthetic_clips(
            int(cfg.get("synthetic_clips", 48)), seed=int(cfg.get("synthetic_seed", 0))
        )
        clips = [_ClipLike(c.name, c.dataset, c.content, c.style, c.features) for c in raw]
    elif source in ("processed", "bandai"):
        from ardy_export.data.dataset import load_clips as data_load_clips

        split = cfg.get("split", "train")
        clips = list(data_load_clips(Path(cfg.get("clips_dir", "data/processed")), split))
    elif source == "bvh":
        from ardy_export.data.dataset import clips_from_bvh_files

        clips = list(clips_from_bvh_files([Path(p) for p in cfg["bvh_files"]]))
    else:
        raise ValueError(f"data.source must be synthetic, processed or bvh, got {source!r}")
    names = cfg.get("clip_names")
    if names:
        wanted = set(names)
        clips = [c for c in clips if c.name in wanted]
    if cfg.get("max_clips"):
        clips = clips[: int(cfg["max_clips"])]
    if not clips:
        raise RuntimeError(f"no clips for the data config {cfg}")
    return clips


def mirror_clip(clip: _ClipLike) -> _ClipLike | None:
    """The left/right mirror of a clip (labels swapped); None without the data package."""
    try:
        from ardy_export.data.augment import mirror_features
        from ardy_export.data.labels import mirror_content
    except ImportError:
        return None
    return replace(
        clip,
        name=clip.name + "_mirror",
        content=mirror_content(clip.content),
        features=np.asarray(mirror_features(clip.features), np.float32),
    )


def load_sequences(cfg: dict[str, Any], rng: np.random.Generator) -> list[TrainSequence]:
    """Training sequences: the clips (plus mirrored copies when ``mirror``), plus
    ``stitched_sequences`` stitched ones of up to ``max_seconds`` (data package)."""
    clips = load_clips(cfg)
    if cfg.get("mirror", False):
        clips = clips + [m for m in (mirror_clip(c) for c in clips) if m is not None]
    seqs = [
        TrainSequence(
            c.name,
            np.asarray(c.features, np.float32),
            [(0, len(c.features), (str(c.dataset), str(c.content), str(c.style)))],
        )
        for c in clips
    ]
    count = int(cfg.get("stitched_sequences", 0))
    if count:
        from ardy_export.data.stitching import build_stitched_sequences

        stitched = build_stitched_sequences(clips, rng, count, float(cfg.get("max_seconds", 10.0)))
        for i, s in enumerate(stitched):
            segs = [
                (int(g.start), int(g.end), (str(g.dataset), str(g.content), str(g.style)))
                for g in s.segments
            ]
            seqs.append(
                TrainSequence(f"stitched_{i:05d}", np.asarray(s.features, np.float32), segs)
            )
    return seqs


def skeleton_for(cfg: dict[str, Any]) -> Skeleton | None:
    """The skeleton of the data (for FK terms and the sampler's FK), None if unknown."""
    if str(cfg.get("source", "synthetic")) == "synthetic":
        return synthetic.synthetic_skeleton()
    try:
        from ardy_export.data.skeleton import default_skeleton
    except ImportError:
        return None
    s = default_skeleton()
    return Skeleton(tuple(s.names), tuple(s.parents), np.asarray(s.offsets, np.float32))


try:  # the data package's yaw rotation when present (same maths as the fallback)
    from ardy_export.data.augment import rotate_yaw as _data_rotate_yaw
except ImportError:  # pragma: no cover
    _data_rotate_yaw = None


def rotate_yaw(features: np.ndarray, angle: float) -> np.ndarray:
    """Rotate world features [T, M] about +Y through the origin by ``angle``."""
    if _data_rotate_yaw is not None:
        return np.asarray(_data_rotate_yaw(features, angle), np.float32)
    return synthetic.rotate_features_yaw(features, angle)


def compute_stats(
    sequences: Sequence[TrainSequence],
    seed: int,
    history_frames: int,
    future_frames: int,
    std_floor: float = 0.01,
) -> tuple[np.ndarray, np.ndarray]:
    """Feature mean and std [M], computed as the runtime re-centers (data package's
    ``compute_normalization_stats`` when present, else the same idea without mirroring)."""
    arrays = [s.features for s in sequences]
    try:
        from ardy_export.data.normalization import (
            compute_normalization_stats,
        )
    except ImportError:
        compute_normalization_stats = None
    if compute_normalization_stats is not None:
        stats = compute_normalization_stats(
            arrays,
            seed=seed,
            history_frames=history_frames,
            future_frames=future_frames,
            std_floor=std_floor,
        )
        return np.asarray(stats.mean, np.float32), np.asarray(stats.std, np.float32)
    rng = np.random.default_rng(seed)
    total = np.zeros(L.FEATURE_SIZE)
    total_sq = np.zeros(L.FEATURE_SIZE)
    count = 0
    for f_all in arrays:
        for _ in range(max(1, len(f_all) // 20)):
            a = int(rng.integers(0, len(f_all)))
            f = rotate_yaw(f_all, float(rng.uniform(-np.pi, np.pi))).astype(np.float64)
            f = f[max(0, a - history_frames) : a + future_frames + 1] - 0.0
            f[:, 0] -= f_all[a, 0]
            f[:, 2] -= f_all[a, 2]
            total += f.sum(0)
            total_sq += (f * f).sum(0)
            count += len(f)
    mean = total / count
    std = np.sqrt(np.maximum(total_sq / count - mean * mean, 0.0))
    return mean.astype(np.float32), np.maximum(std, std_floor).astype(np.float32)


# ----------------------------------------------------------------------------- text


def hashed_embedding(text: str) -> np.ndarray:
    """A deterministic unit vector per (lower-cased, stripped) prompt: the fallback text
    embedding for tests and synthetic data."""
    seed = int.from_bytes(hashlib.sha256(text.strip().lower().encode()).digest()[:8], "little")
    v = np.random.default_rng(seed).standard_normal(TEXT_DIM)
    return (v / np.linalg.norm(v)).astype(np.float32)


def canonical_prompt(key: LabelKey) -> str:
    """The canonical prompt of a label (text package), or ``"content style"`` when the text
    package does not know the label (synthetic data)."""
    try:
        from ardy_export.text import canonical_prompt as text_canonical

        return str(text_canonical(key[1], key[2]))
    except (ImportError, ValueError, KeyError):
        return f"{key[1].replace('-', ' ')} {key[2]}"


def make_embedder(mode: str = "encoder") -> Callable[[str], np.ndarray]:
    """prompt -> embedding [384]: MiniLM (``encoder``) or the hashed fallback (``hashed``)."""
    if mode == "hashed":
        return hashed_embedding
    from ardy_export.text.encoder import TextEncoder

    encoder = TextEncoder()

    def embed(prompt: str) -> np.ndarray:
        return np.asarray(encoder.encode([prompt])[0], np.float32)

    return embed


class TextBank:
    """Sentence embeddings per label for training.

    ``mode = "cache"``: all sentences of the label from the text package's embedding cache
    (``embedding_cache`` path, written by its embed command); ``"encoder"``: the first
    ``sentences`` sentences of the label embedded with MiniLM now; ``"bank"``: a small
    float16 bank written by ``ardy-export text bank``; ``"hashed"``: the hashed
    embedding of the canonical prompt (tests, synthetic data).

    Augmentation, so that prompts worded unlike the training sentences still land near the
    label they describe: ``mix`` is the chance that a drawn embedding is blended with a
    second sentence of the same label (its weight uniform in [0, 1]); ``noise`` the largest
    norm of an isotropic Gaussian offset added to it (its norm uniform in [0, noise]), after
    which it is scaled back to unit length (the encoder's embeddings are L2-normalized).
    Both 0 draw exactly as without them. Held-out paraphrases sit at a cosine of about 0.74
    from their label's nearest training sentence (0.92 between the grammar's sentences);
    an offset of norm 0.9 reaches that.
    """

    def __init__(
        self,
        keys: Sequence[LabelKey],
        mode: str = "hashed",
        sentences: int = 16,
        embedding_cache: str | Path | None = None,
        mix: float = 0.0,
        noise: float = 0.0,
    ) -> None:
        if not 0.0 <= mix <= 1.0 or noise < 0.0:
            raise ValueError(
                f"text augmentation: mix must be in [0, 1] and noise >= 0, got {mix}, {noise}"
            )
        self.mix = mix
        self.noise = noise
        self.embeddings: dict[LabelKey, np.ndarray] = {}
        unique = sorted(set(keys))
        if mode == "hashed":
            for key in unique:
                self.embeddings[key] = hashed_embedding(canonical_prompt(key))[None]
        elif mode == "cache":
            from ardy_export.text.encoder import load_embedding_cache

            if embedding_cache is None:
                raise ValueError("text.mode 'cache' needs text.embedding_cache (an .npz path)")
            cache = load_embedding_cache(embedding_cache)
            for key in unique:
                self.embeddings[key] = np.asarray(cache.label_embeddings(*key), np.float32)
        elif mode == "bank":
            from ardy_export.text.encoder import load_label_bank

            if embedding_cache is None:
                raise ValueError("text.mode 'bank' needs text.embedding_cache (a bank .npz path)")
            bank = load_label_bank(embedding_cache)
            for key in unique:
                if key not in bank:
                    raise ValueError(f"{embedding_cache}: no embeddings for label {key}")
                self.embeddings[key] = bank[key]
        elif mode == "encoder":
            from ardy_export.text import sentences_for
            from ardy_export.text.encoder import TextEncoder

            encoder = TextEncoder()
            for key in unique:
                lines = sentences_for(key[0], key[1], key[2], count=sentences)
                self.embeddings[key] = np.asarray(encoder.encode(lines), np.float32)
        else:
            raise ValueError(f"text.mode must be hashed, cache, bank or encoder, got {mode!r}")

    def sample(self, key: LabelKey, rng: np.random.Generator) -> np.ndarray:
        options = self.embeddings[key]
        drawn = options[int(rng.integers(0, len(options)))]
        if self.mix == 0.0 and self.noise == 0.0:
            return drawn
        if self.mix > 0.0 and len(options) > 1 and rng.random() < self.mix:
            other = options[int(rng.integers(0, len(options)))]
            weight = rng.random()
            drawn = (1.0 - weight) * drawn + weight * other
        if self.noise > 0.0:
            norm = self.noise * rng.random()  # clean and far-off wordings alike
            drawn = drawn + rng.standard_normal(drawn.shape) * (norm / np.sqrt(drawn.size))
        return (drawn / max(float(np.linalg.norm(drawn)), 1e-8)).astype(np.float32)
