"""The autoregressive two-stage denoiser (paper section 3.4, design.md section 5).

All inputs are plain tensors in the model's normalized space (see docs/model_contract.md):

    x_t               [B, C, D]     noisy hybrid tokens of the window (D = 5P + L)
    step              [B] int64     diffusion timestep index t in 0..N-1
    text_embedding    [B, 384]      sentence embedding (ignored where text_keep = 0)
    text_keep         [B]           1: use the text, 0: the learned null text embedding
    history           [B, H, D]     clean hybrid tokens before the window, right-aligned
    history_mask      [B, H]        1 valid, 0 padding (padding first)
    window_goal       [B, C, P*M]   normalized explicit goals of the window frames, patchified
    window_goal_mask  [B, C, P*M]   1 where constrained
    future_goal       [B, F, P*M]   goals of the F tokens after the window
    future_goal_mask  [B, F, P*M]
    future_mask       [B, F]        1: the future token takes part in attention
    constraint_keep   [B]           1: use the goals, 0: drop every constraint of the row

Output: x0 [B, C, D], the predicted clean window tokens.

Token sequence per stage: [step, text, history (H), window (C), future (F)]. Step: learned
embedding per diffusion step; text: linear projection of the embedding or a learned null
vector; motion tokens: one linear projection per kind plus a sinusoidal encoding of the time
position in tokens relative to the window start (history -H..-1, window 0..C-1, future
C..C+F-1). Keys of padded history tokens and of future tokens with future_mask = 0 are
masked out of attention. With ``history_self_only`` history tokens attend only to history
tokens, so their keys and values do not depend on the step, the text, the window or the
goals (they could be computed once per window and cached).

Window token input: the noisy root with the in-window root goals written over it
(``r <- (1 - v_root) r + v_root g_root``), the noisy latent body, the goals and the full mask,
concatenated. The goals are the full explicit goals (root and body) with
``window_goal_input = "full"`` (default: the clean root goal is then also a separate input,
which the network learns to reproduce much faster) or the body goals only with ``"body"``
(the paper). Stage 1 (root transformer) predicts the clean root of the window
tokens; stage 2 (body transformer) takes the same inputs with the window root replaced by
the detached stage-1 root (root goals again written over it) and predicts the clean latent
body. ``two_stage = False`` is the one-stage ablation: one transformer predicts the whole
token. No dropout anywhere.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import Tensor, nn

from ardy_export.models.layers import TransformerStack, attention_bias, sinusoidal_encoding


@dataclass
class DenoiserConfig:
    feature_dim: int = 258
    root_dim: int = 5
    patch: int = 4
    latent_dim: int = 32
    text_dim: int = 384
    window_tokens: int = 10
    max_history_tokens: int = 40
    max_future_tokens: int = 40
    diffusion_steps: int = 10
    width: int = 256
    layers: int = 4
    heads: int = 4
    ff_mult: int = 4
    two_stage: bool = True
    history_self_only: bool = True
    # Goals concatenated to the window tokens: "body" (the paper: body goals, the root goals
    # being written into the root) or "full" (root and body goals, so the clean root goal is
    # also a separate, linearly readable input).
    window_goal_input: str = "full"

    @property
    def window_goal_dim(self) -> int:
        return self.goal_dim if self.window_goal_input == "full" else self.body_goal_dim

    @property
    def root_token_dim(self) -> int:
        return self.root_dim * self.patch

    @property
    def token_dim(self) -> int:
        return self.root_token_dim + self.latent_dim

    @property
    def goal_dim(self) -> int:
        return self.feature_dim * self.patch

    @property
    def body_goal_dim(self) -> int:
        return (self.feature_dim - self.root_dim) * self.patch

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> DenoiserConfig:
        known = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        return cls(**known)


def split_goal(goal: Tensor, config: DenoiserConfig) -> tuple[Tensor, Tensor]:
    """Patchified goal [B, T, P*M] -> (root part [B, T, 5P], body part [B, T, (M-5)P])."""
    batch, tokens, _ = goal.shape
    frames = goal.reshape(batch, tokens, config.patch, config.feature_dim)
    root = frames[..., : config.root_dim].reshape(batch, tokens, config.root_token_dim)
    body = frames[..., config.root_dim :].reshape(batch, tokens, config.body_goal_dim)
    return root, body


def overwrite_root(root: Tensor, goal_root: Tensor, mask_root: Tensor) -> Tensor:
    """``(1 - v) * root + v * goal`` (the in-window root overwrite)."""
    return (1.0 - mask_root) * root + mask_root * goal_root


class _Stage(nn.Module):
    """One transformer over [step, text, history, window, future] with its own embeddings."""

    def __init__(self, config: DenoiserConfig, out_dim: int) -> None:
        super().__init__()
        c = config
        w = c.width
        self.config = c
        self.step_embedding = nn.Embedding(c.diffusion_steps, w)
        self.text_proj = nn.Linear(c.text_dim, w)
        self.null_text = nn.Parameter(torch.zeros(w))
        self.history_proj = nn.Linear(c.token_dim, w)
        self.window_proj = nn.Linear(c.token_dim + c.window_goal_dim + c.goal_dim, w)
        self.future_proj = nn.Linear(2 * c.goal_dim, w)
        self.transformer = TransformerStack(w, c.layers, c.heads, w * c.ff_mult)
        self.head = nn.Linear(w, out_dim)
        nn.init.normal_(self.null_text, std=0.02)

    def forward(
        self,
        window_in: Tensor,
        step: Tensor,
        text_embedding: Tensor,
        text_keep: Tensor,
        history: Tensor,
        history_mask: Tensor,
        future_in: Tensor,
        future_attend: Tensor,
    ) -> Tensor:
        batch, c_tokens, _ = window_in.shape
        h_tokens = history.shape[1]
        f_tokens = future_in.shape[1]
        device = window_in.device
        keep = text_keep.to(window_in.dtype)[:, None]
        text = keep * self.text_proj(text_embedding) + (1.0 - keep) * self.null_text
        step_tok = self.step_embedding(step)
        times = torch.cat(
            (
                torch.arange(h_tokens, device=device) - h_tokens,
                torch.arange(c_tokens, device=device),
                torch.arange(f_tokens, device=device) + c_tokens,
            )
        )
        pos = sinusoidal_encoding(times, self.config.width)
        motion = torch.cat(
            (self.history_proj(history), self.window_proj(window_in), self.future_proj(future_in)),
            dim=1,
        )
        x = torch.cat((step_tok.unsqueeze(1), text.unsqueeze(1), motion + pos), dim=1)

        ones2 = torch.ones(batch, 2, dtype=torch.bool, device=device)
        ones_c = torch.ones(batch, c_tokens, dtype=torch.bool, device=device)
        key_valid = torch.cat((ones2, history_mask > 0.5, ones_c, future_attend > 0.5), dim=1)
        size = x.shape[1]
        allowed = key_valid[:, None, :].expand(batch, size, size)
        if self.config.history_self_only:
            idx = torch.arange(size, device=device)
            is_hist = (idx >= 2) & (idx < 2 + h_tokens)
            forbidden = is_hist[:, None] & ~is_hist[None, :]
            allowed = allowed & ~forbidden[None, :, :]
        y = self.transformer(x, attention_bias(allowed))
        window = y[:, 2 + h_tokens : 2 + h_tokens + c_tokens]
        return self.head(window)


class Denoiser(nn.Module):
    def __init__(self, config: DenoiserConfig) -> None:
        super().__init__()
        self.config = config
        if config.two_stage:
            self.root_stage = _Stage(config, config.root_token_dim)
            self.body_stage = _Stage(config, config.latent_dim)
        else:
            self.joint_stage = _Stage(config, config.token_dim)

    def forward(
        self,
        x_t: Tensor,
        step: Tensor,
        text_embedding: Tensor,
        text_keep: Tensor,
        history: Tensor,
        history_mask: Tensor,
        window_goal: Tensor,
        window_goal_mask: Tensor,
        future_goal: Tensor,
        future_goal_mask: Tensor,
        future_mask: Tensor,
        constraint_keep: Tensor,
    ) -> Tensor:
        c = self.config
        keep = constraint_keep.to(x_t.dtype)
        k3 = keep[:, None, None]
        if c.window_goal_input not in ("body", "full"):
            raise ValueError(
                f"window_goal_input must be 'body' or 'full', got {c.window_goal_input!r}"
            )
        goal = window_goal * k3
        goal_root, goal_body = split_goal(goal, c)
        goal_in = goal if c.window_goal_input == "full" else goal_body
        mask_root, _ = split_goal(window_goal_mask * k3, c)
        window_mask = window_goal_mask * k3
        future_in = torch.cat((future_goal * k3, future_goal_mask * k3), dim=-1)
        future_attend = future_mask * keep[:, None]
        rd = c.root_token_dim
        noisy_root = overwrite_root(x_t[..., :rd], goal_root, mask_root)
        noisy_body = x_t[..., rd:]

        def window_input(root: Tensor) -> Tensor:
            return torch.cat((root, noisy_body, goal_in, window_mask), dim=-1)

        common = (step, text_embedding, text_keep, history, history_mask, future_in, future_attend)
        if not c.two_stage:
            return self.joint_stage(window_input(noisy_root), *common)
        root_hat = self.root_stage(window_input(noisy_root), *common)
        root_in = overwrite_root(root_hat.detach(), goal_root, mask_root)
        body_hat = self.body_stage(window_input(root_in), *common)
        return torch.cat((root_hat, body_hat), dim=-1)
