"""The three model graphs exactly as the runtime calls them (docs/model_contract.md).

Each wrapper is one ``nn.Module`` whose ``forward`` takes and returns plain float32 tensors
(int64 for the diffusion step), with every normalization the runtime should not have to know
about baked in as buffers. The ONNX export traces these modules; the reference sampler calls
the same modules, so PyTorch and ONNX run one definition.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from ardy_export.models.denoiser import Denoiser
from ardy_export.models.tokenizer import BodyTokenizer

# Input and output names of the graphs, in order (the ONNX export and model.json use these).
DENOISER_INPUTS: tuple[str, ...] = (
    "x_t",
    "step",
    "text_embedding",
    "text_keep",
    "history",
    "history_mask",
    "window_goal",
    "window_goal_mask",
    "future_goal",
    "future_goal_mask",
    "future_mask",
    "constraint_keep",
)
DENOISER_OUTPUTS: tuple[str, ...] = ("x0",)
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


def denoiser_graph(denoiser: Denoiser) -> nn.Module:
    """The denoiser's forward already is the graph (inputs in DENOISER_INPUTS order)."""
    return denoiser


@torch.no_grad()
def example_denoiser_inputs(
    denoiser: Denoiser, batch: int, history: int, future: int, seed: int = 0
) -> tuple[Tensor, ...]:
    """Random inputs in DENOISER_INPUTS order (for export and shape tests)."""
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
