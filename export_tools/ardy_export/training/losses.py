"""Training losses of the tokenizer and the denoiser (paper eqs. 6-11)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from ardy_export.diffusion import DiffusionSchedule
from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser
from ardy_export.models.kinematics import fk_world, rot6d_to_matrix
from ardy_export.models.tokenizer import BodyTokenizer


@dataclass
class LossContext:
    """Normalization statistics and skeleton as tensors on the training device."""

    mean: Tensor  # [M]
    std: Tensor  # [M]
    offsets: Tensor | None  # [J, 3]; None disables the FK terms
    parents: Sequence[int]
    fps: float = L.FPS

    def to(self, device: torch.device) -> LossContext:
        return LossContext(
            self.mean.to(device),
            self.std.to(device),
            None if self.offsets is None else self.offsets.to(device),
            self.parents,
            self.fps,
        )


def _planar(root_pos: Tensor) -> Tensor:
    return root_pos * root_pos.new_tensor([1.0, 0.0, 1.0])


def joint_world_from_features(root_pos: Tensor, body_raw: Tensor) -> Tensor:
    """World positions of joints 1..J-1 [..., J-1, 3] from J features and the root p."""
    j = body_raw[..., L.JOINT_POS_SLICE.start - 5 : L.JOINT_POS_SLICE.stop - 5]
    j = j.reshape(*j.shape[:-1], -1, 3)
    return j + _planar(root_pos).unsqueeze(-2)


def foot_skate(root_pos: Tensor, body_raw: Tensor, contacts: Tensor, fps: float) -> Tensor:
    """Eq. 6: sum(c * |foot velocity|) / sum(c) over the foot joints, velocities from the
    predicted foot positions by backward difference (frames 1..N-1)."""
    world = joint_world_from_features(root_pos, body_raw)
    feet = world[..., [j - 1 for j in L.FOOT_JOINTS], :]
    speed = torch.linalg.vector_norm(feet[:, 1:] - feet[:, :-1], dim=-1) * fps
    c = contacts[:, 1:]
    return (c * speed).sum() / (c.sum() + 1e-6)


def _difference_error(
    root_pos: Tensor, body_raw: Tensor, real_body_raw: Tensor, fps: float, order: int
) -> Tensor:
    """Distance between the predicted and the real joints' ``order``-th time difference at
    every difference of the crop [B, N - order, J - 1], in m/s^order."""
    diff = joint_world_from_features(root_pos, body_raw) - joint_world_from_features(
        root_pos, real_body_raw
    )
    for _ in range(order):
        diff = diff[:, 1:] - diff[:, :-1]
    return torch.linalg.vector_norm(diff, dim=-1) * fps**order


def motion_difference_error(
    root_pos: Tensor, body_raw: Tensor, real_body_raw: Tensor, fps: float, order: int
) -> Tensor:
    """Mean distance between the predicted and the real joints' ``order``-th time difference
    over the whole crop, seams included: 1 = velocity (m/s), 2 = acceleration (m/s^2). A seam
    between two tokens' frames that the positions hide (each side close to its own frames)
    is a step in velocity and a spike in acceleration."""
    return _difference_error(root_pos, body_raw, real_body_raw, fps, order).mean()


def seam_difference_error(
    root_pos: Tensor, body_raw: Tensor, real_body_raw: Tensor, fps: float, order: int, patch: int
) -> Tensor:
    """``motion_difference_error`` over the differences whose frames span a seam between two
    tokens' patches only (the crop starts on a patch): where the decoder's patches meet, a
    step that the whole-crop mean dilutes ``patch`` times over."""
    error = _difference_error(root_pos, body_raw, real_body_raw, fps, order)
    # Difference i reads frames i..i+order: it spans the seam before frame k * patch when
    # k * patch - order <= i <= k * patch - 1.
    index = torch.arange(error.shape[1], device=error.device)
    offset = (index + order) % patch
    spans = (offset < order) & (index + order >= patch)
    return error[:, spans].mean()


def fk_consistency(
    root_pos: Tensor, body_raw: Tensor, offsets: Tensor, parents: Sequence[int]
) -> Tensor:
    """Eq. 10: mean L2 distance between predicted joint positions (J) and FK of the predicted
    6D rotations from the root p (metres)."""
    rot6 = body_raw[..., : L.ROT6D_SLICE.stop - 5].reshape(*body_raw.shape[:-1], -1, 6)
    rot = rot6d_to_matrix(rot6)
    fk = fk_world(rot, root_pos, offsets, parents)[..., 1:, :]
    pred = joint_world_from_features(root_pos, body_raw)
    return torch.linalg.vector_norm(fk - pred, dim=-1).mean()


def tokenizer_loss(
    tokenizer: BodyTokenizer,
    batch: Mapping[str, Tensor],
    ctx: LossContext,
    weights: Mapping[str, float],
    skate_contacts: str = "predicted",
) -> tuple[Tensor, dict[str, float]]:
    pred, _ = tokenizer(batch["body"], batch["root"], batch["prev_root"], batch["prev_valid"])
    recon = F.smooth_l1_loss(pred, batch["body"])
    total = weights.get("recon", 1.0) * recon
    parts = {"recon": float(recon.detach())}
    body_raw = pred * ctx.std[5:] + ctx.mean[5:]
    root_pos = batch["raw"][..., L.POS_SLICE]
    if weights.get("skate", 0.0) > 0.0:
        cs = slice(L.CONTACT_SLICE.start - 5, L.CONTACT_SLICE.stop - 5)
        if skate_contacts == "predicted":
            contacts = body_raw[..., cs].detach().clamp(0.0, 1.0)
        else:
            contacts = batch["raw"][..., L.CONTACT_SLICE]
        skate = foot_skate(root_pos, body_raw, contacts, ctx.fps)
        total = total + weights["skate"] * skate
        parts["skate"] = float(skate.detach())
    for name, order in (("velocity", 1), ("acceleration", 2)):
        if weights.get(name, 0.0) > 0.0:
            error = motion_difference_error(
                root_pos, body_raw, batch["raw"][..., L.BODY_SLICE], ctx.fps, order
            )
            total = total + weights[name] * error
            parts[name] = float(error.detach())
    for name, order in (("seam_acceleration", 2), ("seam_jerk", 3)):
        if weights.get(name, 0.0) > 0.0:
            error = seam_difference_error(
                root_pos,
                body_raw,
                batch["raw"][..., L.BODY_SLICE],
                ctx.fps,
                order,
                tokenizer.config.patch,
            )
            total = total + weights[name] * error
            parts[name] = float(error.detach())
    if ctx.offsets is not None and weights.get("fk", 0.0) > 0.0:
        fk = fk_consistency(root_pos, body_raw, ctx.offsets, ctx.parents)
        total = total + weights["fk"] * fk
        parts["fk"] = float(fk.detach())
    parts["loss"] = float(total.detach())
    return total, parts


def _near_root_goals(future_goal_mask: Tensor, keep: Tensor, horizon: int) -> tuple[Tensor, Tensor]:
    """[B, horizon] frames past the window's end with a root (x, z) goal, and [B] the
    windows that have one and kept their constraints."""
    near = future_goal_mask[:, :horizon]
    has_xz = (near[..., 0] > 0) & (near[..., 2] > 0)
    return has_xz, has_xz.any(dim=1) & (keep > 0.5)


def reach_shortfall(
    root_pred: Tensor,
    root_real: Tensor,
    future_goal: Tensor,
    future_goal_mask: Tensor,
    keep: Tensor,
    horizon: int,
) -> Tensor:
    """How much further from the next root waypoint the predicted window ends than the
    data's window did (metres, 0 where it ends as close or closer), averaged over the
    windows with a root (x, z) goal within ``horizon`` frames past their end.

    The sampler writes the window's own root goals into its prediction, so a waypoint
    inside the window is met whatever the network predicts; one just past the window's
    end is met only if the network walks there in time, and the next window's first
    frame cannot jump to it. ``root_pred``/``root_real`` [B, frames, 5] and the goals
    [B, F*P, M] in metres (recentered, denormalized); ``keep`` [B] (constraint_keep)."""
    has_xz, usable = _near_root_goals(future_goal_mask, keep, horizon)
    if not bool(usable.any()):
        return root_pred.new_zeros(())
    first = torch.argmax(has_xz.to(torch.int64), dim=1)
    rows = torch.arange(len(first), device=first.device)
    goal = future_goal[rows, first][:, [0, 2]]
    pred_gap = torch.linalg.norm(root_pred[:, -1, [0, 2]] - goal, dim=-1)
    real_gap = torch.linalg.norm(root_real[:, -1, [0, 2]] - goal, dim=-1)
    shortfall = F.relu(pred_gap - real_gap)
    return shortfall[usable].mean()


def reach_path_error(
    root_pred: Tensor,
    root_real: Tensor,
    future_goal_mask: Tensor,
    keep: Tensor,
    horizon: int,
) -> Tensor:
    """Mean distance (metres) between the predicted and the data's root (x, z) over every
    frame of the windows with a root waypoint within ``horizon`` frames past their end.

    ``reach_shortfall`` asks this of the last frame only, and the model met it by lunging
    in a window's last frames; asked of the whole path, the waypoint can only be met by
    walking there as the data did. Shapes as ``reach_shortfall``."""
    _, usable = _near_root_goals(future_goal_mask, keep, horizon)
    if not bool(usable.any()):
        return root_pred.new_zeros(())
    gap = torch.linalg.norm(root_pred[..., [0, 2]] - root_real[..., [0, 2]], dim=-1)
    return gap.mean(dim=1)[usable].mean()


def _root_speed(root: Tensor, fps: float) -> Tensor:
    """[B, frames - 1] horizontal root speed (m/s) of each frame step of [B, frames, 5]."""
    return torch.linalg.norm(torch.diff(root[..., [0, 2]], dim=1), dim=-1) * fps


def reach_speed_excess(
    root_pred: Tensor,
    root_real: Tensor,
    future_goal_mask: Tensor,
    keep: Tensor,
    horizon: int,
    fps: float,
) -> Tensor:
    """How much faster (m/s) the predicted root moves than the data's fastest frame of the
    same window, averaged over every frame of the windows with a root waypoint within
    ``horizon`` frames past their end (0 where it is no faster).

    Beside ``reach_shortfall`` it leaves one way to end near the next waypoint: walking
    there at the data's pace from earlier in the window, not a lunge in the last frames
    (which that term alone taught). Shapes as ``reach_shortfall``."""
    _, usable = _near_root_goals(future_goal_mask, keep, horizon)
    if not bool(usable.any()):
        return root_pred.new_zeros(())
    fastest_real = _root_speed(root_real, fps).amax(dim=1, keepdim=True)
    return F.relu(_root_speed(root_pred, fps) - fastest_real).mean(dim=1)[usable].mean()


def end_speed_excess(root_pred: Tensor, root_real: Tensor, fps: float, frames: int) -> Tensor:
    """How much faster (m/s) the predicted root moves than the data's over the same frame
    steps, over the last ``frames`` steps of every window (0 where it is no faster).

    The reach term taught a lunge in a window's last frames, and the lunge showed in
    windows without any waypoint ahead too (stage 21, whose speed limit acted only where
    the reach term did); asked of every window, per frame, it leaves no window a lunge the
    data did not make (stage 24: it did, and the reach term's waypoint gain went with
    the lunge). Shapes as ``reach_shortfall``."""
    excess = _root_speed(root_pred, fps) - _root_speed(root_real, fps)
    return F.relu(excess[:, -frames:]).mean()


def denoiser_loss(
    denoiser: nn.Module,
    decoder: nn.Module,
    schedule: DiffusionSchedule,
    batch: Mapping[str, Tensor],
    ctx: LossContext,
    weights: Mapping[str, float],
    generator: torch.Generator | None = None,
) -> tuple[Tensor, dict[str, float]]:
    """Hybrid + decoded body + goal + FK consistency (eq. 11), and optionally foot skate
    under the data's contacts (eq. 6 on the decoded prediction), weights from the config.

    ``decoder`` is the frozen DecoderGraph (normalized hybrid tokens -> normalized body);
    gradients flow through it into the prediction only.
    """
    x0 = batch["x0"]
    b, c, _ = x0.shape
    inner: Denoiser = denoiser.module if hasattr(denoiser, "module") else denoiser  # type: ignore[assignment]
    cfg = inner.config
    t = torch.randint(0, schedule.num_steps, (b,), generator=generator).to(x0.device)
    noise = torch.randn(x0.shape, generator=generator).to(x0.device)
    x_t = schedule.q_sample(x0, t, noise)
    x0_hat = denoiser(
        x_t,
        t,
        batch["text_embedding"],
        batch["text_keep"],
        batch["history"],
        batch["history_mask"],
        batch["window_goal"],
        batch["window_goal_mask"],
        batch["future_goal"],
        batch["future_goal_mask"],
        batch["future_mask"],
        batch["constraint_keep"],
    )
    # Per-group weights (as Kimodo): the root part of the token can be weighted up
    # (hybrid_root, default 1); normalized so that equal weights give the plain mean.
    per = F.smooth_l1_loss(x0_hat, x0, reduction="none")
    w_root = float(weights.get("hybrid_root", 1.0))
    group = torch.ones(x0.shape[-1], device=x0.device)
    group[: cfg.root_token_dim] = w_root
    hybrid = (per * group).mean() / group.mean()
    total = weights.get("hybrid", 1.0) * hybrid
    parts = {"hybrid": float(hybrid.detach())}
    reach_terms = ("reach", "reach_path", "reach_speed", "end_speed")
    decoded_terms = ("decoded", "goal", "fk", "skate", *reach_terms)
    need_decode = any(weights.get(k, 0.0) > 0.0 for k in decoded_terms)
    if need_decode:
        body_hat = decoder(x0_hat, batch["prev_root"], batch["prev_valid"])
        rd = cfg.root_token_dim
        frames = c * cfg.patch
        root_hat = x0_hat[..., :rd].reshape(b, frames, cfg.root_dim)
        root_raw = root_hat * ctx.std[: L.ROOT_DIM] + ctx.mean[: L.ROOT_DIM]
        body_raw = body_hat * ctx.std[L.ROOT_DIM :] + ctx.mean[L.ROOT_DIM :]
        if weights.get("decoded", 0.0) > 0.0:
            dec = F.smooth_l1_loss(body_hat, batch["body"])
            total = total + weights["decoded"] * dec
            parts["decoded"] = float(dec.detach())
        if weights.get("goal", 0.0) > 0.0:
            explicit = torch.cat((root_hat, body_hat), dim=-1)
            keep = batch["constraint_keep"][:, None, None]
            mask = batch["window_goal_mask"].reshape(b, frames, -1) * keep
            goal = batch["window_goal"].reshape(b, frames, -1)
            gl = (mask * (explicit - goal)).abs().sum() / (mask.sum() + 1.0)
            total = total + weights["goal"] * gl
            parts["goal"] = float(gl.detach())
        if any(weights.get(k, 0.0) > 0.0 for k in reach_terms):
            real = x0[..., :rd].reshape(b, frames, cfg.root_dim)
            real_raw = real * ctx.std[: L.ROOT_DIM] + ctx.mean[: L.ROOT_DIM]
            future_mask = batch["future_goal_mask"].reshape(b, -1, L.FEATURE_SIZE)
            near = 2 * cfg.patch  # the first two future tokens (0.4 s)
            if weights.get("reach", 0.0) > 0.0:
                goals = batch["future_goal"].reshape(b, -1, L.FEATURE_SIZE)
                reach = reach_shortfall(
                    root_raw,
                    real_raw,
                    goals * ctx.std + ctx.mean,
                    future_mask,
                    batch["constraint_keep"],
                    near,
                )
                total = total + weights["reach"] * reach
                parts["reach"] = float(reach.detach())
            if weights.get("reach_path", 0.0) > 0.0:
                path = reach_path_error(
                    root_raw, real_raw, future_mask, batch["constraint_keep"], near
                )
                total = total + weights["reach_path"] * path
                parts["reach_path"] = float(path.detach())
            if weights.get("reach_speed", 0.0) > 0.0:
                excess = reach_speed_excess(
                    root_raw, real_raw, future_mask, batch["constraint_keep"], near, ctx.fps
                )
                total = total + weights["reach_speed"] * excess
                parts["reach_speed"] = float(excess.detach())
            if weights.get("end_speed", 0.0) > 0.0:
                lunge = end_speed_excess(root_raw, real_raw, ctx.fps, cfg.patch)
                total = total + weights["end_speed"] * lunge
                parts["end_speed"] = float(lunge.detach())
        if weights.get("skate", 0.0) > 0.0:
            # Contact-aware: the decoded feet of the predicted motion must not slide where
            # the data's contact labels say a foot is planted (eq. 6 on the prediction).
            contacts = batch["body"][..., L.CONTACT_SLICE.start - L.ROOT_DIM :]
            contacts = contacts * ctx.std[L.CONTACT_SLICE] + ctx.mean[L.CONTACT_SLICE]
            skate = foot_skate(root_raw[..., L.POS_SLICE], body_raw, contacts.clamp(0, 1), ctx.fps)
            total = total + weights["skate"] * skate
            parts["skate"] = float(skate.detach())
        if ctx.offsets is not None and weights.get("fk", 0.0) > 0.0:
            fk = fk_consistency(root_raw[..., L.POS_SLICE], body_raw, ctx.offsets, ctx.parents)
            total = total + weights["fk"] * fk
            parts["fk"] = float(fk.detach())
    parts["loss"] = float(total.detach())
    return total, parts
