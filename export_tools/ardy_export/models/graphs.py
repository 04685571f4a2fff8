"""The model graphs exactly as the runtime calls them (docs/model_contract.md).

Each wrapper is one ``nn.Module`` whose ``forward`` takes and returns plain float32 tensors
(int64 for the diffusion step), with every normalization the runtime should not have to know
about baked in as buffers. The ONNX export traces these modules; the reference sampler calls
the same modules, so PyTorch and ONNX run one definition.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.tokenizer import BodyTokenizer

# Input and output names of the graphs, in order (the ONNX export and model.json use these).
# The denoiser graph takes the history as the keys and values the history graph computed
# once per window, and the goals as the goals graph's embeddings, also once per window
# (``Denoiser.forward_cached``); ``DENOISER_MODULE_INPUTS`` are the arguments of
# ``Denoiser.forward``, the uncached reference the training and the reference sampler run.
HISTORY_INPUTS: tuple[str, ...] = ("history", "history_mask")
HISTORY_OUTPUTS: tuple[str, ...] = ("history_kv",)
GOALS_INPUTS: tuple[str, ...] = (
    "window_goal",
    "window_goal_mask",
    "future_goal",
    "future_goal_mask",
)
GOALS_OUTPUTS: tuple[str, ...] = (
    "window_root_goal",
    "window_root_mask",
    "window_goal_embedding",
    "future_embedding",
)
DENOISER_INPUTS: tuple[str, ...] = (
    "x_t",
    "step",
    "text_embedding",
    "text_keep",
    *HISTORY_OUTPUTS,
    "history_mask",
    *GOALS_OUTPUTS,
    "future_mask",
    "constraint_keep",
)
DENOISER_OUTPUTS: tuple[str, ...] = ("x0",)
DENOISER_MODULE_INPUTS: tuple[str, ...] = (
    "x_t",
    "step",
    "text_embedding",
    "text_keep",
    *HISTORY_INPUTS,
    *GOALS_INPUTS,
    "future_mask",
    "constraint_keep",
)
DECODER_INPUTS: tuple[str, ...] = ("tokens", "prev_root", "prev_root_valid")
DECODER_OUTPUTS: tuple[str, ...] = ("body",)
ENCODER_INPUTS: tuple[str, ...] = ("body",)
ENCODER_OUTPUTS: tuple[str, ...] = ("latent",)


class EncoderGraph(nn.Module):
    """body [B, T*P, 253] (normalized) -> latent [B, T, L] (normalized with latent stats)."""

    def __init__(self, tokenizer: BodyTokenizer, latent_mean: Tensor, latent_std: Tensor) -> None:
        super().__init__()
        self.tokenizer = tokenizer
        self.register_buffer("latent_mean", latent_mean.detach().clone().float())
        self.register_buffer("latent_std", latent_std.detach().clone().float())

    def forward(self, body: Tensor) -> Tensor:
        return (self.tokenizer.encode(body) - self.latent_mean) / self.latent_std


class DecoderGraph(nn.Module):
    """tokens [B, T, D] (normalized hybrid), prev_root [B, 5] (normalized), prev_root_valid
    [B] -> body [B, T*P, 253] (normalized)."""

    def __init__(self, tokenizer: BodyTokenizer, latent_mean: Tensor, latent_std: Tensor) -> None:
        super().__init__()
        self.tokenizer = tokenizer
        self.register_buffer("latent_mean", latent_mean.detach().clone().float())
        self.register_buffer("latent_std", latent_std.detach().clone().float())

    def forward(self, tokens: Tensor, prev_root: Tensor, prev_root_valid: Tensor) -> Tensor:
        cfg = self.tokenizer.config
        batch, count, _ = tokens.shape
        rd = cfg.root_dim * cfg.patch
        root = tokens[..., :rd].reshape(batch, count * cfg.patch, cfg.root_dim)
        codes = tokens[..., rd:] * self.latent_std + self.latent_mean
        return self.tokenizer.decode(codes, root, prev_root, prev_root_valid)


class HistoryGraph(nn.Module):
    """history [B, H, D], history_mask [B, H] -> history_kv [B, stages * layers, 2, heads, H,
    head_dim]: every layer's keys and values of the history (once per window). Called with
    H >= 1 only (ONNX Reshape reads a 0 in a shape as "keep this axis"); without history the
    keys and values are the empty tensor of ``history_kv_shape(config, B, 0)``."""

    def __init__(self, denoiser: Denoiser) -> None:
        super().__init__()
        self.denoiser = denoiser

    def forward(self, history: Tensor, history_mask: Tensor) -> Tensor:
        return self.denoiser.history_keys_values(history, history_mask)


class GoalsGraph(nn.Module):
    """The window's goals -> what they contribute to every step (once per window):
    window_root_goal, window_root_mask [B, C, 5P], window_goal_embedding [B, stages, C, W],
    future_embedding [B, stages, F, W] (``Denoiser.goal_embeddings``)."""

    def __init__(self, denoiser: Denoiser) -> None:
        super().__init__()
        self.denoiser = denoiser

    def forward(
        self,
        window_goal: Tensor,
        window_goal_mask: Tensor,
        future_goal: Tensor,
        future_goal_mask: Tensor,
    ) -> tuple[Tensor, Tensor, Tensor, Tensor]:
        return self.denoiser.goal_embeddings(
            window_goal, window_goal_mask, future_goal, future_goal_mask
        )


class DenoiserGraph(nn.Module):
    """The denoiser with the history as ``history_kv`` and the goals as the goals graph's
    outputs (inputs in DENOISER_INPUTS order)."""

    def __init__(self, denoiser: Denoiser) -> None:
        super().__init__()
        self.denoiser = denoiser

    def forward(
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
        return self.denoiser.forward_cached(
            x_t,
            step,
            text_embedding,
            text_keep,
            history_kv,
            history_mask,
            window_root_goal,
            window_root_mask,
            window_goal_embedding,
            future_embedding,
            future_mask,
            constraint_keep,
        )


def history_kv_shape(config: DenoiserConfig, batch: int, history: int) -> tuple[int, ...]:
    """Shape of ``history_kv``: [B, stages * layers, 2, heads, H, head_dim]."""
    stages = 2 if config.two_stage else 1
    head_dim = config.width // config.heads
    return (batch, stages * config.layers, 2, config.heads, history, head_dim)


def cached_inputs(denoiser: Denoiser, module_inputs: tuple[Tensor, ...]) -> tuple[Tensor, ...]:
    """DENOISER_MODULE_INPUTS values -> DENOISER_INPUTS values (the history replaced by its
    keys and values, the goals by their embeddings)."""
    given = dict(zip(DENOISER_MODULE_INPUTS, module_inputs, strict=True))
    given["history_kv"] = denoiser.history_keys_values(given["history"], given["history_mask"])
    goals = denoiser.goal_embeddings(*(given[name] for name in GOALS_INPUTS))
    given.update(zip(GOALS_OUTPUTS, goals, strict=True))
    return tuple(given[name] for name in DENOISER_INPUTS)


@torch.no_grad()
def example_denoiser_inputs(
    denoiser: Denoiser, batch: int, history: int, future: int, seed: int = 0
) -> tuple[Tensor, ...]:
    """Random inputs in DENOISER_MODULE_INPUTS order (for export and shape tests)."""
    c = denoiser.config
    g = torch.Generator().manual_seed(seed)
    d, gd = c.token_dim, c.goal_dim
    hist_mask = torch.ones(batch, history)
    if history > 1:
        hist_mask[0, : history // 2] = 0.0
    fut_mask = (torch.rand(batch, future, generator=g) > 0.3).float()
    wmask = (torch.rand(batch, c.window_tokens, gd, generator=g) > 0.9).float()
    fgmask = (torch.rand(batch, future, gd, generator=g) > 0.9).float() * fut_mask[..., None]
    return (
        torch.randn(batch, c.window_tokens, d, generator=g),
        torch.randint(0, c.diffusion_steps, (batch,), generator=g),
        torch.randn(batch, c.text_dim, generator=g),
        torch.ones(batch),
        torch.randn(batch, history, d, generator=g) * hist_mask[..., None],
        hist_mask,
        torch.randn(batch, c.window_tokens, gd, generator=g) * wmask,
        wmask,
        torch.randn(batch, future, gd, generator=g) * fgmask,
        fgmask,
        fut_mask,
        torch.ones(batch),
    )
