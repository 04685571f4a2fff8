"""Evaluation metrics (numpy): foot skate, R-precision, FID, jerk.

Motion arguments are world joint positions [T, J, 3] (metres, Y up) or a sequence of such
clips; a sequence is pooled over all its frames, each clip's velocities computed on its own
(no difference across a clip boundary). Embedding arguments are [N, dim] arrays.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import linalg

from ardy_export.data.config import load_data_config
from ardy_export.data.features import joint_velocities

Motion = np.ndarray | Sequence[np.ndarray]


def _clips(positions: Motion) -> list[np.ndarray]:
    if isinstance(positions, np.ndarray) and positions.ndim == 3:
        return [np.asarray(positions, dtype=np.float64)]
    return [np.asarray(p, dtype=np.float64) for p in positions]


def foot_skate(
    positions: Motion,
    foot_joints: Sequence[int],
    fps: float,
    height_threshold: float | Sequence[float] | None = None,
) -> float:
    """Mean horizontal speed (m/s) of the foot joints over the frames where they are below
    their height threshold, pooled over joints and frames (the ARDY paper's foot skate).

    ``height_threshold``: one height (m) for all ``foot_joints`` or one per joint; None takes
    ``skate.height`` of configs/data.yaml (Foot_L, Toes_L, Foot_R, Toes_R; ``foot_joints``
    must then be those four in that order, ``ardy_export.data.skeleton.FOOT_JOINTS``). This
    is ``ardy_export.data.contacts.foot_skate`` computed from positions instead of features.
    Returns NaN when no foot joint is ever low.
    """
    feet = list(foot_joints)
    if height_threshold is None:
        height_threshold = load_data_config().skate_height
    limits = np.broadcast_to(np.asarray(height_threshold, dtype=np.float64), (len(feet),))
    speeds = []
    for p in _clips(positions):
        velocities = joint_velocities(p[:, feet], fps)
        low = p[:, feet, 1] < limits
        speeds.append(np.hypot(velocities[..., 0], velocities[..., 2])[low])
    pooled = np.concatenate(speeds) if speeds else np.zeros(0)
    return float(pooled.mean()) if pooled.size else float("nan")


def jerk(positions: np.ndarray, fps: float) -> np.ndarray:
    """Per-frame jerk [T - 3] (m/s^3): the third finite difference of each joint's position
    times fps^3, its magnitude averaged over the joints."""
    p = np.asarray(positions, dtype=np.float64)
    third = np.diff(p, n=3, axis=0) * fps**3
    return np.linalg.norm(third, axis=-1).mean(axis=-1)


def mean_jerk(positions: Motion, fps: float) -> float:
    """``jerk`` averaged over all frames of one clip [T, J, 3] or a sequence of clips."""
    per_frame = np.concatenate([jerk(p, fps) for p in _clips(positions)])
    return float(per_frame.mean()) if per_frame.size else float("nan")


def _unit(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return x / np.maximum(np.linalg.norm(x, axis=-1, keepdims=True), 1e-12)


def r_precision_hits(
    motion_emb: np.ndarray,
    text_emb: np.ndarray,
    top_k: int = 3,
    pool: int = 32,
    seed: int = 0,
    label_ids: Sequence[int] | np.ndarray | None = None,
) -> np.ndarray:
    """R-precision (Guo et al. 2022) per motion: whether the motion's own text (row i of
    ``text_emb`` belongs to row i of ``motion_emb``) ranks in the ``top_k`` by cosine
    similarity among a pool of ``pool`` texts: its own and ``pool - 1`` others drawn at random.

    With ``label_ids`` the others carry distinct labels, all different from the motion's (so
    no other text in the pool describes it equally well). A tie with the own text counts as
    a hit only if fewer than ``top_k`` texts score strictly higher.
    """
    motion = _unit(motion_emb)
    text = _unit(text_emb)
    count = motion.shape[0]
    if text.shape[0] != count:
        raise ValueError("r_precision: motion_emb and text_emb need the same number of rows")
    rng = np.random.default_rng(seed)
    if label_ids is None:
        if count < pool:
            raise ValueError(f"r_precision: {count} pairs cannot fill a pool of {pool}")
    else:
        labels = np.asarray(label_ids)
        unique = np.unique(labels)
        if len(unique) < pool:
            raise ValueError(f"r_precision: {len(unique)} labels cannot fill a pool of {pool}")
        members = {label: np.flatnonzero(labels == label) for label in unique}
    hits = np.zeros(count, bool)
    for i in range(count):
        if label_ids is None:
            others = rng.choice(count - 1, pool - 1, replace=False)
            others += others >= i  # skip i itself
        else:
            chosen = rng.choice(unique[unique != labels[i]], pool - 1, replace=False)
            others = np.array([rng.choice(members[label]) for label in chosen])
        own = motion[i] @ text[i]
        hits[i] = np.sum(text[others] @ motion[i] > own) < top_k
    return hits


def r_precision(
    motion_emb: np.ndarray,
    text_emb: np.ndarray,
    top_k: int = 3,
    pool: int = 32,
    seed: int = 0,
    label_ids: Sequence[int] | np.ndarray | None = None,
) -> float:
    """The fraction of ``r_precision_hits``."""
    hits = r_precision_hits(motion_emb, text_emb, top_k, pool, seed, label_ids)
    return float(hits.mean()) if hits.size else float("nan")


def r_precision_chance(top_k: int, pool: int) -> float:
    """R-precision of random embeddings: ``top_k / pool``."""
    return min(1.0, top_k / pool)


def fid(real_emb: np.ndarray, gen_emb: np.ndarray) -> float:
    """Fréchet distance between Gaussians fitted to two embedding sets [N, dim]:
    ``|mu_r - mu_g|^2 + tr(S_r + S_g - 2 (S_r S_g)^(1/2))``."""
    real = np.asarray(real_emb, dtype=np.float64)
    gen = np.asarray(gen_emb, dtype=np.float64)
    mu_r, mu_g = real.mean(axis=0), gen.mean(axis=0)
    cov_r = np.atleast_2d(np.cov(real, rowvar=False))
    cov_g = np.atleast_2d(np.cov(gen, rowvar=False))
    covmean = linalg.sqrtm(cov_r @ cov_g)
    if not np.isfinite(covmean).all():  # singular product: regularize (as pytorch-fid does)
        eps = np.eye(cov_r.shape[0]) * 1e-6
        covmean = linalg.sqrtm((cov_r + eps) @ (cov_g + eps))
    covmean = np.real(covmean)
    value = np.sum((mu_r - mu_g) ** 2) + np.trace(cov_r + cov_g - 2.0 * covmean)
    return float(max(value, 0.0))


def multimodal_distance(motion_emb: np.ndarray, text_emb: np.ndarray) -> float:
    """Mean Euclidean distance between each motion embedding and its own text's."""
    diff = np.asarray(motion_emb, np.float64) - np.asarray(text_emb, np.float64)
    return float(np.linalg.norm(diff, axis=-1).mean())


def seam_jerk(positions: Motion, fps: float, patch: int) -> dict[str, float]:
    """Jerk at the decoder's patch seams against jerk inside a patch, for motion whose frame 0
    starts a patch (every rollout of the runtime: its tokens start at frame 0).

    ``jerk`` entry i spans frames i .. i+3. *Across*: the entries centred on a seam (frames
    ``k*patch - 2 .. k*patch + 1``); *inside*: those within one patch (``k*patch ..
    k*patch + 3``). Both pooled over the clips; ``ratio`` = across / inside (about 1 for
    motion without seams, such as real clips)."""
    if patch < 4:
        raise ValueError("seam_jerk: a patch of fewer than 4 frames holds no third difference")
    across, inside = [], []
    for clip in _clips(positions):
        per_frame = jerk(clip, fps)
        phase = np.arange(len(per_frame)) % patch
        across.append(per_frame[phase == patch - 2])
        inside.append(per_frame[phase == 0])
    a = np.concatenate(across) if across else np.zeros(0)
    i = np.concatenate(inside) if inside else np.zeros(0)
    across_mean = float(a.mean()) if a.size else float("nan")
    inside_mean = float(i.mean()) if i.size else float("nan")
    ratio = across_mean / inside_mean if inside_mean > 0 else float("nan")
    return {"across_seams": across_mean, "inside_patches": inside_mean, "ratio": ratio}


def contact_agreement(
    positions: Motion, contacts: np.ndarray | Sequence[np.ndarray], fps: float
) -> float:
    """Fraction of (frame, foot joint) where a motion's own contact flags (> 0.5; [T, 4] per
    clip, Foot_L, Toes_L, Foot_R, Toes_R) agree with the data's contact rule (height and 3D
    speed under the thresholds of configs/data.yaml ``contacts``,
    ``ardy_export.data.contacts.compute_contacts``) applied to the same motion's positions."""
    from ardy_export.data.contacts import compute_contacts

    clips = _clips(positions)
    flags = [contacts] if isinstance(contacts, np.ndarray) and contacts.ndim == 2 else contacts
    if len(flags) != len(clips):
        raise ValueError("contact_agreement: one contact array per clip")
    agree, total = 0, 0
    for p, c in zip(clips, flags, strict=True):
        own = np.asarray(c) > 0.5
        rule = compute_contacts(p, fps=fps) > 0.5
        if own.shape != rule.shape:
            raise ValueError(f"contact_agreement: contacts {own.shape}, expected {rule.shape}")
        agree += int((own == rule).sum())
        total += own.size
    return agree / total if total else float("nan")


def balanced_indices(
    label_ids: Sequence[int] | np.ndarray, per_label: int, seed: int = 0
) -> np.ndarray:
    """Indices drawing ``per_label`` items of every label (with replacement, so a label with
    fewer items repeats some), in label order: a label-balanced sample of an unevenly
    spread set."""
    labels = np.asarray(label_ids)
    rng = np.random.default_rng(seed)
    picks = [
        rng.choice(np.flatnonzero(labels == label), per_label, replace=True)
        for label in np.unique(labels)
    ]
    return np.concatenate(picks) if picks else np.zeros(0, dtype=np.int64)
