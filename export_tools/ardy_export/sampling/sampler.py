"""The reference sampler: the executable specification the C++ runtime follows.

One window (``sample_windows``): DDIM with x0 prediction from explicit noise, all guidance
branches of all windows in one denoiser call per step, the in-window root overwrite of the
guided x0 at every step, then ``decode_window`` (tokenizer decoder over context + window
tokens), ``window_features`` (un-normalize, un-center) and ``features_to_motion`` (6D ->
rotation, global -> local rotations, FK).

Autoregressive rollout (``rollout``): windows one after the other; each keeps its first
``commit_tokens`` tokens; the history of the next window is the last ``history_tokens``
committed tokens, re-centered by translation only on the last history frame (the
configured start position when there is no history); the window takes the prompt active at
its first frame; world-space constraints become that window's goals (``constraints.py``).

Everything in float32 except where a docstring says otherwise; see docs/model_contract.md
for the exact order of operations.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import Tensor

from ardy_export.diffusion import DiffusionSchedule, ddim_timesteps
from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.graphs import DENOISER_MODULE_INPUTS, DecoderGraph, EncoderGraph
from ardy_export.models.kinematics import fk_world, global_to_local, rot6d_to_matrix
from ardy_export.models.layout import Skeleton
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig
from ardy_export.sampling.constraints import Constraint, WindowGoals, window_goals
from ardy_export.sampling.guidance import Branch, combine, guidance_branches, is_late_step


@dataclass
class ModelBundle:
    """Everything the sampler needs: the three graphs, schedule, statistics, skeleton."""

    tokenizer: BodyTokenizer
    denoiser: Denoiser
    schedule: DiffusionSchedule
    mean: np.ndarray  # [M] feature normalization
    std: np.ndarray  # [M]
    latent_mean: np.ndarray  # [L]
    latent_std: np.ndarray  # [L]
    skeleton: Skeleton | None = None
    defaults: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        lm = torch.as_tensor(self.latent_mean, dtype=torch.float32)
        ls = torch.as_tensor(self.latent_std, dtype=torch.float32)
        self.decoder_graph = DecoderGraph(self.tokenizer, lm, ls).eval()
        self.encoder_graph = EncoderGraph(self.tokenizer, lm, ls).eval()
        self.denoiser.eval()

    @property
    def config(self) -> DenoiserConfig:
        return self.denoiser.config

    @classmethod
    def from_checkpoint(cls, path: str | Path, use_ema: bool = True) -> ModelBundle:
        """Load a denoiser checkpoint written by ``ardy-export train denoiser``."""
        ckpt = torch.load(Path(path), map_location="cpu", weights_only=False)
        return cls.from_state(ckpt, use_ema=use_ema)

    @classmethod
    def from_state(cls, ckpt: dict[str, Any], use_ema: bool = True) -> ModelBundle:
        tok = BodyTokenizer(TokenizerConfig.from_dict(ckpt["tokenizer_config"]))
        tok.load_state_dict(ckpt["tokenizer"])
        den = Denoiser(DenoiserConfig.from_dict(ckpt["denoiser_config"]))
        weights = ckpt.get("ema") if use_ema and ckpt.get("ema") is not None else ckpt["model"]
        den.load_state_dict(weights)
        skel = None
        if ckpt.get("skeleton") is not None:
            s = ckpt["skeleton"]
            skel = Skeleton(
                tuple(s["names"]), tuple(s["parents"]), np.asarray(s["offsets"], np.float32)
            )
        return cls(
            tokenizer=tok.eval(),
            denoiser=den.eval(),
            schedule=DiffusionSchedule(np.asarray(ckpt["alphas_cumprod"], dtype=np.float64)),
            mean=np.asarray(ckpt["stats"]["mean"], np.float32),
            std=np.asarray(ckpt["stats"]["std"], np.float32),
            latent_mean=np.asarray(ckpt["latent_stats"]["mean"], np.float32),
            latent_std=np.asarray(ckpt["latent_stats"]["std"], np.float32),
            skeleton=skel,
            defaults=dict(ckpt.get("sampling_defaults", {})),
        )


@dataclass
class WindowRequest:
    """One window to generate (all arrays float32, model frame, normalized)."""

    history: np.ndarray  # [H, D], H may be 0
    text_embedding: np.ndarray | None  # [text_dim]; None: no prompt (text branch skipped)
    goals: WindowGoals
    noise: np.ndarray  # [C, D] standard normal


# The denoiser's inputs after x_t and step, in its argument order (``_pack_rows`` keys).
PACKED_INPUTS = DENOISER_MODULE_INPUTS[2:]


def call_denoiser(
    denoiser: torch.nn.Module, x_t: Tensor, step: Tensor, packed: dict[str, Tensor]
) -> Tensor:
    """One denoiser call on all rows of ``_pack_rows``'s inputs."""
    return denoiser(x_t, step, *(packed[name] for name in PACKED_INPUTS))


def _pack_rows(
    requests: Sequence[WindowRequest], branches: Sequence[Sequence[Branch]], cfg: DenoiserConfig
) -> dict[str, Tensor]:
    """The denoiser inputs (minus x_t and step) for all branch rows of all windows.

    History is right-aligned and padded at the front to the longest history; future goal
    tokens are padded at the back to the longest future. Padding is zeros with mask 0.
    """
    rows = sum(len(b) for b in branches)
    h_max = max(r.history.shape[0] for r in requests)
    f_max = max(r.goals.future_tokens for r in requests)
    c, d, gd = cfg.window_tokens, cfg.token_dim, cfg.goal_dim
    t = {
        "text_embedding": torch.zeros(rows, cfg.text_dim),
        "text_keep": torch.zeros(rows),
        "history": torch.zeros(rows, h_max, d),
        "history_mask": torch.zeros(rows, h_max),
        "window_goal": torch.zeros(rows, c, gd),
        "window_goal_mask": torch.zeros(rows, c, gd),
        "future_goal": torch.zeros(rows, f_max, gd),
        "future_goal_mask": torch.zeros(rows, f_max, gd),
        "future_mask": torch.zeros(rows, f_max),
        "constraint_keep": torch.zeros(rows),
    }
    i = 0
    for req, brs in zip(requests, branches, strict=True):
        h = req.history.shape[0]
        f = req.goals.future_tokens
        for br in brs:
            if req.text_embedding is not None:
                t["text_embedding"][i] = torch.from_numpy(req.text_embedding)
            t["text_keep"][i] = br.text_keep
            t["constraint_keep"][i] = br.constraint_keep
            if h:
                t["history"][i, h_max - h :] = torch.from_numpy(req.history)
                t["history_mask"][i, h_max - h :] = 1.0
            t["window_goal"][i] = torch.from_numpy(req.goals.window_goal)
            t["window_goal_mask"][i] = torch.from_numpy(req.goals.window_goal_mask)
            if f:
                t["future_goal"][i, :f] = torch.from_numpy(req.goals.future_goal)
                t["future_goal_mask"][i, :f] = torch.from_numpy(req.goals.future_goal_mask)
                t["future_mask"][i, :f] = torch.from_numpy(req.goals.future_mask)
            i += 1
    return t


def window_root_goal(goals: WindowGoals, cfg: DenoiserConfig) -> tuple[Tensor, Tensor]:
    """Root part of the in-window goal and mask as [C, 5P] (frame-major)."""
    c, p, m = cfg.window_tokens, cfg.patch, cfg.feature_dim
    g = torch.from_numpy(goals.window_goal).reshape(c, p, m)[..., : cfg.root_dim]
    v = torch.from_numpy(goals.window_goal_mask).reshape(c, p, m)[..., : cfg.root_dim]
    return g.reshape(c, p * cfg.root_dim), v.reshape(c, p * cfg.root_dim)


@torch.no_grad()
def sample_windows(
    denoiser: Denoiser,
    schedule: DiffusionSchedule,
    requests: Sequence[WindowRequest],
    steps: int,
    w_text: float = 2.0,
    w_con: float = 2.0,
    root_overwrite: bool = True,
    path_guidance_scale: float = 1.0,
    text_only_guidance_scale: float = 1.0,
) -> list[np.ndarray]:
    """DDIM for a batch of windows; returns the clean tokens [C, D] of each (normalized).

    ``root_overwrite=False`` skips the overwrite of the guided x0 (for tests that measure
    what the network itself learned; the runtime always overwrites).
    ``path_guidance_scale`` multiplies ``w_con`` in windows whose goals are a dense root path
    alone (``WindowGoals.root_path_only``); ``text_only_guidance_scale`` multiplies ``w_text``
    in windows with no goals, at the steps in the upper half of the schedule (the late steps
    keep ``w_text``).
    """
    cfg = denoiser.config
    branches = [
        guidance_branches(
            w_text if r.goals.has_constraints else w_text * text_only_guidance_scale,
            w_con * path_guidance_scale if r.goals.root_path_only else w_con,
            r.text_embedding is not None,
            r.goals.has_constraints,
            late_w_text=w_text,
        )
        for r in requests
    ]
    packed = _pack_rows(requests, branches, cfg)
    rd = cfg.root_token_dim
    root_goals = [window_root_goal(r.goals, cfg) for r in requests]
    x = [torch.from_numpy(np.ascontiguousarray(r.noise, dtype=np.float32)) for r in requests]
    timesteps = ddim_timesteps(schedule.num_steps, steps)
    x0_list: list[Tensor] = []
    for i, t in enumerate(timesteps):
        late = is_late_step(t, schedule.num_steps)
        x_rows = torch.cat(
            [xi.unsqueeze(0).expand(len(b), -1, -1) for xi, b in zip(x, branches, strict=True)]
        )
        step = torch.full((x_rows.shape[0],), t, dtype=torch.int64)
        out = call_denoiser(denoiser, x_rows, step, packed)
        x0_list = []
        start = 0
        for (g_root, v_root), brs in zip(root_goals, branches, strict=True):
            x0 = combine(out[start : start + len(brs)], brs, late)
            start += len(brs)
            if root_overwrite:
                root = (1.0 - v_root) * x0[:, :rd] + v_root * g_root
                x0 = torch.cat((root, x0[:, rd:]), dim=-1)
            x0_list.append(x0)
        if i + 1 < len(timesteps):
            x = [
                schedule.ddim_step(xi, x0, t, timesteps[i + 1])
                for xi, x0 in zip(x, x0_list, strict=True)
            ]
    return [x0.numpy() for x0 in x0_list]


@torch.no_grad()
def decode_window(
    bundle: ModelBundle, context: np.ndarray, window: np.ndarray, prev_root: np.ndarray | None
) -> np.ndarray:
    """Decode [context; window] tokens (normalized, model frame) and keep the window's
    frames: normalized body [C*P, 253]. ``prev_root`` [5] (normalized) is the root of the
    frame before the first context token, None if there is none."""
    tokens = np.concatenate((context, window), axis=0)[None].astype(np.float32)
    prev = np.zeros((1, 5), np.float32) if prev_root is None else prev_root[None].astype(np.float32)
    valid = np.array([0.0 if prev_root is None else 1.0], np.float32)
    body = bundle.decoder_graph(
        torch.from_numpy(tokens), torch.from_numpy(prev), torch.from_numpy(valid)
    )[0].numpy()
    frames = window.shape[0] * bundle.tokenizer.config.patch
    return body[-frames:]


def window_features(
    tokens: np.ndarray,
    body: np.ndarray,
    mean: np.ndarray,
    std: np.ndarray,
    offset_xz: Sequence[float],
    patch: int = L.PATCH,
) -> np.ndarray:
    """World explicit features [C*P, M] from normalized window tokens [C, D] and decoded
    normalized body [C*P, 253]: ``x * std + mean``, then + offset on p.x and p.z."""
    c = tokens.shape[0]
    root = tokens[:, : 5 * patch].reshape(c * patch, 5)
    feat = np.concatenate((root, body), axis=1).astype(np.float32) * std + mean
    feat[:, 0] += np.float32(offset_xz[0])
    feat[:, 2] += np.float32(offset_xz[1])
    return feat.astype(np.float32)


@dataclass
class Motion:
    global_rotations: np.ndarray  # [T, J, 3, 3]
    local_rotations: np.ndarray  # [T, J, 3, 3]
    positions: np.ndarray  # [T, J, 3] world, by FK of the rotations from p


def features_to_motion(features: np.ndarray, skeleton: Skeleton) -> Motion:
    """6D -> rotation (Gram-Schmidt), world -> parent-relative rotations, FK from p."""
    f = torch.from_numpy(np.ascontiguousarray(features, dtype=np.float32))
    j = skeleton.num_joints
    rot = rot6d_to_matrix(f[:, L.ROT6D_SLICE].reshape(-1, j, 6))
    local = global_to_local(rot, skeleton.parents)
    pos = fk_world(rot, f[:, L.POS_SLICE], torch.from_numpy(skeleton.offsets), skeleton.parents)
    return Motion(rot.numpy(), local.numpy(), pos.numpy())


@dataclass(frozen=True)
class PromptEvent:
    frame: int
    text: str | None  # None: no prompt from this frame on


@dataclass
class RolloutConfig:
    steps: int = 4
    w_text: float = 2.0
    w_con: float = 2.0
    history_tokens: int = 40
    future_tokens: int = 10
    decode_context_tokens: int = 4
    commit_tokens: int | None = None  # tokens kept per window (default: the whole window)
    start_xz: tuple[float, float] = (0.0, 0.0)
    root_overwrite: bool = True
    interpolate_root: bool = False  # constraints.interpolate_root on every window's goals
    path_guidance_scale: float = 1.0  # sample_windows: w_con times this on dense-path windows
    text_only_guidance_scale: float = 1.0  # sample_windows: w_text times this without goals


@dataclass
class RolloutResult:
    features: np.ndarray  # [T, M] world
    tokens: np.ndarray  # [T/P, D]: root world (un-normalized, un-centered), latent normalized
    window_starts: list[int]
    prompts: list[str | None]
    motion: Motion | None


def active_prompt(prompts: Sequence[PromptEvent], frame: int) -> str | None:
    """The text of the last event at or before ``frame`` (ties: the later in the list)."""
    text: str | None = None
    best = -1
    for ev in prompts:
        if best <= ev.frame <= frame:
            best = ev.frame
            text = ev.text
    return text


def history_tokens_for_window(
    world_root: np.ndarray,
    latent: np.ndarray,
    mean: np.ndarray,
    std: np.ndarray,
    offset_xz: Sequence[float],
) -> np.ndarray:
    """Normalized re-centered history tokens [H, D] from committed world roots [H, P, 5] and
    normalized latents [H, L]."""
    h, p, _ = world_root.shape
    root = world_root.astype(np.float32).copy()
    root[..., 0] -= np.float32(offset_xz[0])
    root[..., 2] -= np.float32(offset_xz[1])
    root = (root - mean[:5]) / std[:5]
    return np.concatenate((root.reshape(h, p * 5), latent), axis=1).astype(np.float32)


def rollout(
    bundle: ModelBundle,
    embed: Callable[[str], np.ndarray],
    prompts: Sequence[PromptEvent],
    constraints: Sequence[Constraint],
    num_windows: int,
    config: RolloutConfig | None = None,
    noise: np.ndarray | None = None,
    seed: int = 0,
) -> RolloutResult:
    """Generate ``num_windows`` windows autoregressively (module docstring).

    ``noise`` [num_windows, C, D] fixes the initial noise of each window (goldens);
    otherwise window w uses ``np.random.default_rng(seed).standard_normal`` draws in order.
    """
    cfg = config or RolloutConfig()
    dc = bundle.config
    c, p, d = dc.window_tokens, dc.patch, dc.token_dim
    commit = cfg.commit_tokens or c
    if not 1 <= commit <= c:
        raise ValueError(f"commit_tokens must be in 1..{c}, got {commit}")
    rng = np.random.default_rng(seed)
    mean = bundle.mean.astype(np.float32)
    std = bundle.std.astype(np.float32)
    world_root = np.zeros((0, p, 5), np.float32)
    latent = np.zeros((0, dc.latent_dim), np.float32)
    feats: list[np.ndarray] = []
    starts: list[int] = []
    used: list[str | None] = []
    cache: dict[str, np.ndarray] = {}
    rd = dc.root_token_dim
    for w in range(num_windows):
        committed = world_root.shape[0]
        start = committed * p
        h = min(committed, cfg.history_tokens)
        offset = (float(world_root[-1, -1, 0]), float(world_root[-1, -1, 2])) if h else cfg.start_xz
        hist = history_tokens_for_window(
            world_root[committed - h :], latent[committed - h :], mean, std, offset
        )
        text = active_prompt(prompts, start)
        emb = None
        if text is not None:
            if text not in cache:
                cache[text] = np.asarray(embed(text), dtype=np.float32)
            emb = cache[text]
        goals = window_goals(
            constraints, start, offset, mean, std, c, cfg.future_tokens, p, cfg.interpolate_root
        )
        win_noise = (
            noise[w].astype(np.float32)
            if noise is not None
            else rng.standard_normal((c, d)).astype(np.float32)
        )
        req = WindowRequest(hist, emb, goals, win_noise)
        (x0,) = sample_windows(
            bundle.denoiser,
            bundle.schedule,
            [req],
            cfg.steps,
            cfg.w_text,
            cfg.w_con,
            cfg.root_overwrite,
            cfg.path_guidance_scale,
            cfg.text_only_guidance_scale,
        )
        k = min(h, cfg.decode_context_tokens)
        context = hist[h - k :]
        prev_root = hist[h - k - 1, rd - 5 : rd] if h - k - 1 >= 0 else None
        body = decode_window(bundle, context, x0, prev_root)
        f = window_features(x0, body, mean, std, offset, p)
        feats.append(f[: commit * p])
        starts.append(start)
        used.append(text)
        root_world = f[: commit * p, :5].reshape(commit, p, 5)
        world_root = np.concatenate((world_root, root_world), axis=0)
        latent = np.concatenate((latent, x0[:commit, rd:]), axis=0)
    features = np.concatenate(feats, axis=0)
    tokens = np.concatenate((world_root.reshape(-1, p * 5), latent), axis=1)
    motion = features_to_motion(features, bundle.skeleton) if bundle.skeleton else None
    return RolloutResult(features, tokens, starts, used, motion)
