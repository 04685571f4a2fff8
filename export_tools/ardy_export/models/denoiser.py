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
goals: ``history_keys_values`` computes them once per window and ``forward_cached`` takes
them in place of the history (the exported graphs, docs/model_contract.md).

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

import re
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from ardy_export.models.layers import (
    MASKED,
    ConditionModulation,
    Modulation,
    TransformerStack,
    attention_bias,
    sinusoidal_encoding,
)


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
    # Every layer's attention and feed-forward of the step, text, window and future tokens
    # shifted, scaled and gated from the step and text tokens (``ConditionModulation``), as
    # well as the text being one token among the others. History tokens are never
    # modulated, so their keys and values stay independent of the step and the text.
    condition_modulation: bool = False

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
        self.modulation = ConditionModulation(w, c.layers) if c.condition_modulation else None
        nn.init.normal_(self.null_text, std=0.02)

    def _modulations(self, x: Tensor, h_tokens: int) -> list[Modulation] | None:
        """Every layer's modulation from the embedded step and text tokens (``x``'s first
        two), with the ``h_tokens`` history tokens after them left unmodulated."""
        if self.modulation is None:
            return None
        condition = x[:, 0] + x[:, 1]
        if h_tokens == 0:
            return self.modulation(condition)
        weight = torch.ones(x.shape[1], dtype=x.dtype, device=x.device)
        weight[2 : 2 + h_tokens] = 0.0
        return self.modulation(condition, weight)

    def _embed(
        self,
        window_embedding: Tensor,
        future_embedding: Tensor,
        step: Tensor,
        text_embedding: Tensor,
        text_keep: Tensor,
        history: Tensor | None,
    ) -> Tensor:
        """Embedded tokens [step, text, history, window, future] from the projected window
        and future tokens (no history when None)."""
        c_tokens = window_embedding.shape[1]
        h_tokens = 0 if history is None else history.shape[1]
        f_tokens = future_embedding.shape[1]
        device = window_embedding.device
        keep = text_keep.to(window_embedding.dtype)[:, None]
        text = keep * self.text_proj(text_embedding) + (1.0 - keep) * self.null_text
        step_tok = self.step_embedding(step)
        times = torch.cat(
            (
                torch.arange(c_tokens, device=device),
                torch.arange(f_tokens, device=device) + c_tokens,
            )
        )
        parts = [window_embedding, future_embedding]
        if history is not None:
            times = torch.cat((torch.arange(h_tokens, device=device) - h_tokens, times))
            parts.insert(0, self.history_proj(history))
        motion = torch.cat(parts, dim=1) + sinusoidal_encoding(times, self.config.width)
        return torch.cat((step_tok.unsqueeze(1), text.unsqueeze(1), motion), dim=1)

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
        device = window_in.device
        x = self._embed(
            self.window_proj(window_in),
            self.future_proj(future_in),
            step,
            text_embedding,
            text_keep,
            history,
        )
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
        y = self.transformer(x, attention_bias(allowed), None, self._modulations(x, h_tokens))
        window = y[:, 2 + h_tokens : 2 + h_tokens + c_tokens]
        return self.head(window)

    def history_keys_values(self, history: Tensor, history_mask: Tensor) -> Tensor:
        """Keys and values of the history tokens in every layer, [B, layers, 2, heads, H,
        head_dim] (2: keys, values). With ``history_self_only`` they are what ``forward``
        computes for the history, whatever the step, text, window and goals."""
        self._require_history_self_only()
        batch, h_tokens, _ = history.shape
        times = torch.arange(h_tokens, device=history.device) - h_tokens
        x = self.history_proj(history) + sinusoidal_encoding(times, self.config.width)
        allowed = (history_mask > 0.5)[:, None, :].expand(batch, h_tokens, h_tokens)
        layers = self.transformer.keys_values(x, attention_bias(allowed))
        return torch.stack([torch.stack(keys_values, dim=1) for keys_values in layers], dim=1)

    def token_embedding(self, token: Tensor) -> Tensor:
        """The part of ``window_proj`` that reads the window token [B, C, D] (with its bias):
        the part that changes at every step."""
        d = self.config.token_dim
        return F.linear(token, self.window_proj.weight[:, :d], self.window_proj.bias)

    def goal_embeddings(
        self, goal_in: Tensor, window_mask: Tensor, future_in: Tensor
    ) -> tuple[Tensor, Tensor]:
        """The parts of the input projections that read the goals: the window goals' share of
        ``window_proj`` (no bias) [B, C, W] and the future tokens' ``future_proj`` [B, F, W].
        ``window_proj(cat(token, goal_in, window_mask))`` is ``token_embedding(token)`` plus
        the first; they do not change from step to step."""
        d = self.config.token_dim
        goals = torch.cat((goal_in, window_mask), dim=-1)
        return F.linear(goals, self.window_proj.weight[:, d:]), self.future_proj(future_in)

    def forward_cached(
        self,
        window_embedding: Tensor,
        future_embedding: Tensor,
        step: Tensor,
        text_embedding: Tensor,
        text_keep: Tensor,
        history_keys_values: Tensor,
        history_mask: Tensor,
        future_attend: Tensor,
    ) -> Tensor:
        """``forward`` from the projected window and future tokens, with the history given as
        ``history_keys_values``: only the step, text, window and future tokens are computed;
        their keys follow the history's."""
        self._require_history_self_only()
        batch, c_tokens, _ = window_embedding.shape
        h_tokens = history_mask.shape[1]
        device = window_embedding.device
        x = self._embed(window_embedding, future_embedding, step, text_embedding, text_keep, None)
        size = x.shape[1]
        ones = torch.ones(batch, 2 + c_tokens, dtype=torch.bool, device=device)
        key_valid = torch.cat((history_mask > 0.5, ones, future_attend > 0.5), dim=1)
        # Every token may attend to itself (attention_bias's diagonal): its key sits after
        # the H history keys.
        own = torch.cat(
            (
                torch.zeros(size, h_tokens, dtype=torch.bool, device=device),
                torch.eye(size, dtype=torch.bool, device=device),
            ),
            dim=1,
        )
        allowed = key_valid[:, None, :] | own[None, :, :]
        bias = torch.where(
            allowed,
            torch.zeros((), dtype=torch.float32, device=device),
            torch.full((), MASKED, dtype=torch.float32, device=device),
        ).unsqueeze(1)
        prefixes = [
            (history_keys_values[:, layer, 0], history_keys_values[:, layer, 1])
            for layer in range(self.config.layers)
        ]
        y = self.transformer(x, bias, prefixes, self._modulations(x, 0))
        return self.head(y[:, 2 : 2 + c_tokens])

    def _require_history_self_only(self) -> None:
        if not self.config.history_self_only:
            raise ValueError(
                "cached history keys and values need history_self_only = true (with it off, "
                "history tokens attend to the step, text and window, so they change every call)"
            )


class Denoiser(nn.Module):
    def __init__(self, config: DenoiserConfig) -> None:
        super().__init__()
        self.config = config
        if config.two_stage:
            self.root_stage = _Stage(config, config.root_token_dim)
            self.body_stage = _Stage(config, config.latent_dim)
        else:
            self.joint_stage = _Stage(config, config.token_dim)

    @property
    def stages(self) -> list[_Stage]:
        return [self.root_stage, self.body_stage] if self.config.two_stage else [self.joint_stage]

    def load_grown(self, state: Mapping[str, Tensor]) -> int:
        """Load a trained denoiser of the same sizes that this one grows: fewer transformer
        layers per stage, or no condition modulation, or both. Its layers come first; the
        added layers start as the identity and the added modulation at zero, so this model
        computes what that one did and training goes on from there. Returns the layers
        loaded per stage."""
        layer_key = re.compile(r"\.transformer\.layers\.(\d+)\.")
        modulation_key = re.compile(r"\.modulation\.")
        loaded = 1 + max(
            (int(m.group(1)) for key in state if (m := layer_key.search(key))), default=-1
        )
        if not 0 < loaded <= self.config.layers:
            raise ValueError(
                f"a denoiser with {loaded} layers per stage cannot grow to {self.config.layers}"
            )
        missing, unexpected = self.load_state_dict(state, strict=False)
        added = [
            key
            for key in missing
            if ((m := layer_key.search(key)) and int(m.group(1)) >= loaded)
            or modulation_key.search(key)
        ]
        if unexpected or len(added) != len(missing):
            raise ValueError(
                "the checkpoint differs from this denoiser in more than its layer count and "
                f"modulation: missing {sorted(set(missing) - set(added))[:3]}, "
                f"unexpected {unexpected[:3]}"
            )
        for stage in self.stages:
            for layer in stage.transformer.layers[loaded:]:
                layer.zero_residual()
        # A modulation not in the checkpoint keeps its zero start (ConditionModulation).
        return loaded

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
        goal_in, window_mask, future_in = self._goal_inputs(
            window_goal * k3, window_goal_mask * k3, future_goal * k3, future_goal_mask * k3
        )
        goal_root, _ = split_goal(window_goal * k3, c)
        mask_root, _ = split_goal(window_goal_mask * k3, c)
        future_attend = future_mask * keep[:, None]
        noisy_body = x_t[..., c.root_token_dim :]

        def run(index: int, root: Tensor) -> Tensor:
            window_in = torch.cat((root, noisy_body, goal_in, window_mask), dim=-1)
            return self.stages[index](
                window_in,
                step,
                text_embedding,
                text_keep,
                history,
                history_mask,
                future_in,
                future_attend,
            )

        return self._two_stages(run, x_t, goal_root, mask_root)

    def history_keys_values(self, history: Tensor, history_mask: Tensor) -> Tensor:
        """Keys and values of the history in every layer of every stage, [B, stages * layers,
        2, heads, H, head_dim] (root stage first): computed once per window, they serve
        every step and guidance row (``forward_cached``)."""
        per_stage = [stage.history_keys_values(history, history_mask) for stage in self.stages]
        return torch.cat(per_stage, dim=1)

    def goal_embeddings(
        self,
        window_goal: Tensor,
        window_goal_mask: Tensor,
        future_goal: Tensor,
        future_goal_mask: Tensor,
    ) -> tuple[Tensor, Tensor, Tensor, Tensor]:
        """What the goals contribute, computed once per window (the goals as given, i.e. for
        constraint_keep = 1): the in-window root goal and mask in token layout [B, C, 5P]
        each, the window goals' share of every stage's window projection [B, stages, C, W]
        and every stage's future token projection [B, stages, F, W]."""
        c = self.config
        goal_root, _ = split_goal(window_goal, c)
        mask_root, _ = split_goal(window_goal_mask, c)
        goal_in, window_mask, future_in = self._goal_inputs(
            window_goal, window_goal_mask, future_goal, future_goal_mask
        )
        embeddings = [
            stage.goal_embeddings(goal_in, window_mask, future_in) for stage in self.stages
        ]
        window = torch.stack([window for window, _ in embeddings], dim=1)
        future = torch.stack([future for _, future in embeddings], dim=1)
        return goal_root, mask_root, window, future

    def forward_cached(
        self,
        x_t: Tensor,
        step: Tensor,
        text_embedding: Tensor,
        text_keep: Tensor,
        history_kv: Tensor,
        history_mask: Tensor,
        window_root_goal: Tensor,
        window_root_mask: Tensor,
        window_goal_embedding: Tensor,
        future_embedding: Tensor,
        future_mask: Tensor,
        constraint_keep: Tensor,
    ) -> Tensor:
        """``forward`` with ``history_kv = history_keys_values(history, history_mask)`` and
        ``goal_embeddings(...)`` of the window's goals in place of the history and the goals:
        the same x0 within float rounding, without recomputing either at every step."""
        c = self.config
        keep = constraint_keep.to(x_t.dtype)
        k3 = keep[:, None, None]
        goal_root = window_root_goal * k3
        mask_root = window_root_mask * k3
        future_attend = future_mask * keep[:, None]
        noisy_body = x_t[..., c.root_token_dim :]

        def run(index: int, root: Tensor) -> Tensor:
            stage = self.stages[index]
            token = torch.cat((root, noisy_body), dim=-1)
            window = stage.token_embedding(token) + k3 * window_goal_embedding[:, index]
            return stage.forward_cached(
                window,
                future_embedding[:, index],
                step,
                text_embedding,
                text_keep,
                history_kv[:, index * c.layers : (index + 1) * c.layers],
                history_mask,
                future_attend,
            )

        return self._two_stages(run, x_t, goal_root, mask_root)

    def _goal_inputs(
        self,
        window_goal: Tensor,
        window_goal_mask: Tensor,
        future_goal: Tensor,
        future_goal_mask: Tensor,
    ) -> tuple[Tensor, Tensor, Tensor]:
        """(window goals beside each token, the window's mask, future tokens' input)."""
        c = self.config
        if c.window_goal_input not in ("body", "full"):
            raise ValueError(
                f"window_goal_input must be 'body' or 'full', got {c.window_goal_input!r}"
            )
        goal_in = window_goal if c.window_goal_input == "full" else split_goal(window_goal, c)[1]
        future_in = torch.cat((future_goal, future_goal_mask), dim=-1)
        return goal_in, window_goal_mask, future_in

    def _two_stages(
        self,
        run: Callable[[int, Tensor], Tensor],
        x_t: Tensor,
        goal_root: Tensor,
        mask_root: Tensor,
    ) -> Tensor:
        """The stages around ``run(stage_index, window_root)``, which runs one stage's
        transformer on the window with that root (``stages`` order): the noisy root with the
        root goals written over it, then (two stages) the detached stage-1 root, again with
        the goals over it."""
        noisy_root = overwrite_root(x_t[..., : self.config.root_token_dim], goal_root, mask_root)
        if not self.config.two_stage:
            return run(0, noisy_root)
        root_hat = run(0, noisy_root)
        body_hat = run(1, overwrite_root(root_hat.detach(), goal_root, mask_root))
        return torch.cat((root_hat, body_hat), dim=-1)
