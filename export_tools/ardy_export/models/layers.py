"""Transformer building blocks shared by the tokenizer and the denoiser.

Plain pre-norm encoder layers written out (fused QKV projection, scaled dot-product
attention, GELU feed-forward, no dropout) rather than ``nn.TransformerEncoder``, so that
the masks are explicit additive biases, the ONNX export sees ordinary ops, and keys and
values of a block of tokens could later be cached.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor, nn

# Additive attention bias of a forbidden (query, key) pair. Finite so that the softmax of a
# row never sees only -inf; every query may always attend to itself as well (see
# ``attention_bias``), so a padded row still has one finite score.
MASKED = -1.0e9


def sinusoidal_encoding(positions: Tensor, width: int) -> Tensor:
    """Sinusoidal encoding of float positions [S] -> [S, width].

    ``enc[s, 2i] = sin(pos_s * f_i)``, ``enc[s, 2i + 1] = cos(pos_s * f_i)`` with
    ``f_i = exp(-ln(10000) * 2i / width)``. ``width`` must be even.
    """
    half = width // 2
    freqs = torch.exp(
        torch.arange(half, dtype=torch.float32, device=positions.device)
        * (-math.log(10000.0) * 2.0 / width)
    )
    angles = positions.to(torch.float32)[:, None] * freqs[None, :]
    return torch.stack((torch.sin(angles), torch.cos(angles)), dim=-1).reshape(-1, 2 * half)


def attention_bias(allowed: Tensor) -> Tensor:
    """Boolean ``allowed`` [B, S, S] (query, key) -> additive bias [B, 1, S, S].

    The diagonal is always allowed, so no row is empty.
    """
    size = allowed.shape[-1]
    eye = torch.eye(size, dtype=torch.bool, device=allowed.device)
    allowed = allowed | eye
    zero = torch.zeros((), dtype=torch.float32, device=allowed.device)
    masked = torch.full((), MASKED, dtype=torch.float32, device=allowed.device)
    return torch.where(allowed, zero, masked).unsqueeze(1)


class SelfAttention(nn.Module):
    def __init__(self, width: int, heads: int) -> None:
        super().__init__()
        if width % heads != 0:
            raise ValueError(f"width {width} is not divisible by heads {heads}")
        self.heads = heads
        self.head_dim = width // heads
        self.qkv = nn.Linear(width, 3 * width)
        self.out = nn.Linear(width, width)

    def forward(self, x: Tensor, bias: Tensor) -> Tensor:
        batch, size, width = x.shape
        qkv = self.qkv(x).reshape(batch, size, 3, self.heads, self.head_dim)
        q, k, v = qkv.permute(2, 0, 3, 1, 4).unbind(0)
        y = F.scaled_dot_product_attention(q, k, v, attn_mask=bias)
        return self.out(y.transpose(1, 2).reshape(batch, size, width))


class EncoderLayer(nn.Module):
    """Pre-norm transformer layer: x + attn(ln(x)), then x + mlp(ln(x))."""

    def __init__(self, width: int, heads: int, ff_width: int) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(width)
        self.attn = SelfAttention(width, heads)
        self.norm2 = nn.LayerNorm(width)
        self.ff = nn.Sequential(nn.Linear(width, ff_width), nn.GELU(), nn.Linear(ff_width, width))

    def forward(self, x: Tensor, bias: Tensor) -> Tensor:
        x = x + self.attn(self.norm1(x), bias)
        return x + self.ff(self.norm2(x))


class TransformerStack(nn.Module):
    """``layers`` pre-norm layers and a final LayerNorm."""

    def __init__(self, width: int, layers: int, heads: int, ff_width: int) -> None:
        super().__init__()
        self.layers = nn.ModuleList(EncoderLayer(width, heads, ff_width) for _ in range(layers))
        self.norm = nn.LayerNorm(width)

    def forward(self, x: Tensor, bias: Tensor) -> Tensor:
        for layer in self.layers:
            x = layer(x, bias)
        return self.norm(x)
