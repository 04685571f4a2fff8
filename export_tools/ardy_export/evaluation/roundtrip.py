"""``ardy-export eval tokenizer``: what the tokenizer alone does to real motion.

The test clips are encoded and decoded as the runtime decodes a window: 10 tokens at a
time, each window given the root of the frame before it. The decoded motion is measured
against the clips themselves, so these figures are the floor any denoiser on this
tokenizer starts from: foot skate (the paper's metric), jerk across the decoder's patch
seams against jerk inside a patch, joint position error, and how often the decoded foot
contacts agree with the data's contact rule applied to the decoded motion.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch

from ardy_export.data.dataset import load_clips
from ardy_export.data.features import positions_from_features
from ardy_export.evaluation import metrics
from ardy_export.models import layout as L
from ardy_export.models.tokenizer import BodyTokenizer


@torch.no_grad()
def decode_like_runtime(
    tokenizer: BodyTokenizer,
    features: np.ndarray,
    mean: np.ndarray,
    std: np.ndarray,
    window_tokens: int,
) -> np.ndarray:
    """Features [T, M] of a clip (T a multiple of the patch) encoded, then decoded window by
    window; the root is the clip's own."""
    norm = torch.from_numpy(((features - mean) / std).astype(np.float32))[None]
    codes = tokenizer.encode(norm[..., L.BODY_SLICE])
    patch = tokenizer.config.patch
    root = norm[..., L.ROOT_SLICE]
    bodies = []
    for first in range(0, codes.shape[1], window_tokens):
        last = min(first + window_tokens, codes.shape[1])
        frames = slice(first * patch, last * patch)
        prev_frame = max(first * patch - 1, 0)
        body = tokenizer.decode(
            codes[:, first:last],
            root[:, frames],
            root[:, prev_frame],
            torch.tensor([1.0 if first > 0 else 0.0]),
        )
        bodies.append(body[0].numpy())
    out = features.copy()
    out[:, L.BODY_SLICE] = np.concatenate(bodies) * std[L.BODY_SLICE] + mean[L.BODY_SLICE]
    return out


def evaluate_tokenizer(
    tokenizer: BodyTokenizer,
    mean: np.ndarray,
    std: np.ndarray,
    data: str | Path,
    split: str = "test",
    window_tokens: int = 10,
) -> dict[str, Any]:
    """The round trip of every clip of ``split`` measured against the clip (module doc)."""
    tokenizer.eval()
    patch = tokenizer.config.patch
    real, decoded = [], []
    for clip in load_clips(data, split=split):
        frames = len(clip.features) // patch * patch
        if frames < 4 * patch:
            continue
        features = np.asarray(clip.features[:frames], np.float64)
        real.append(features)
        decoded.append(decode_like_runtime(tokenizer, features, mean, std, window_tokens))
    fps = L.FPS
    feet = list(L.FOOT_JOINTS)

    def measures(motion: list[np.ndarray]) -> dict[str, Any]:
        positions = [positions_from_features(f) for f in motion]
        return {
            "foot_skate": metrics.foot_skate(positions, feet, fps),
            "jerk": metrics.mean_jerk(positions, fps),
            "seam_jerk": metrics.seam_jerk(positions, fps, patch),
            "contact_agreement": metrics.contact_agreement(
                positions, [f[:, L.CONTACT_SLICE] for f in motion], fps
            ),
        }

    error = np.concatenate(
        [
            np.linalg.norm(positions_from_features(d) - positions_from_features(r), axis=-1)
            for d, r in zip(decoded, real, strict=True)
        ]
    )
    return {
        "clips": len(real),
        "frames": int(sum(len(r) for r in real)),
        "real": measures(real),
        "decoded": {**measures(decoded), "joint_error_m": float(error.mean())},
    }
