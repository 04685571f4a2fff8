"""Transformer building blocks shared by the tokenizer and the denoiser.

Plain pre-norm encoder layers written out (fused QKV projection, scaled dot-product
attention, GELU feed-forward, no dropout) rather than ``nn.TransformerEncoder``, so that
the masks are explicit additive biases, the ONNX export sees ordinary ops, and keys and
values of a block of tokens can be cached (``TransformerStack.keys_values`` and the
``prefixes`` of its ``forward``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import cast

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


# Keys and values of one layer for a block of tokens computed elsewhere (the cached
# history): two tensors [B, heads, S, head_dim], put before the keys of the call's own tokens.
KeysValues = tuple[Tensor, Tensor]

# Per-token modulation of one layer (``ConditionModulation``): shift, scale and gate of the
# attention input and output, then of the feed-forward's, six tensors [B, S or 1, W]; all
# zero is the unmodulated layer.
Modulation = tuple[Tensor, Tensor, Tensor, Tensor, Tensor, Tensor]


class SelfAttention(nn.Module):
    def __init__(self, width: int, heads: int) -> None:
        super().__init__()
        if width % heads != 0:
            raise ValueError(f"width {width} is not divisible by heads {heads}")
        self.heads = heads
        self.head_dim = width // heads
        self.qkv = nn.Linear(width, 3 * width)
        self.out = nn.Linear(width, width)

    def project(self, x: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        """x [B, S, W] -> q, k, v, each [B, heads, S, head_dim]."""
        batch, size, _ = x.shape
        qkv = self.qkv(x).reshape(batch, size, 3, self.heads, self.head_dim)
        q, k, v = qkv.permute(2, 0, 3, 1, 4).unbind(0)
        return q, k, v

    def attend(self, q: Tensor, k: Tensor, v: Tensor, bias: Tensor) -> Tensor:
        batch, _, size, _ = q.shape
        y = F.scaled_dot_product_attention(q, k, v, attn_mask=bias)
        return self.out(y.transpose(1, 2).reshape(batch, size, self.heads * self.head_dim))

    def forward(self, x: Tensor, bias: Tensor, prefix: KeysValues | None = None) -> Tensor:
        """``prefix``: keys and values put before the tokens' own (``bias`` covers both)."""
        q, k, v = self.project(x)
        if prefix is not None:
            k = torch.cat((prefix[0], k), dim=2)
            v = torch.cat((prefix[1], v), dim=2)
        return self.attend(q, k, v, bias)


class EncoderLayer(nn.Module):
    """Pre-norm transformer layer: x + attn(ln(x)), then x + mlp(ln(x))."""

    def __init__(self, width: int, heads: int, ff_width: int) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(width)
        self.attn = SelfAttention(width, heads)
        self.norm2 = nn.LayerNorm(width)
        self.ff = nn.Sequential(nn.Linear(width, ff_width), nn.GELU(), nn.Linear(ff_width, width))

    def forward(
        self,
        x: Tensor,
        bias: Tensor,
        prefix: KeysValues | None = None,
        modulation: Modulation | None = None,
    ) -> Tensor:
        if modulation is None:
            x = x + self.attn(self.norm1(x), bias, prefix)
            return x + self.ff(self.norm2(x))
        shift1, scale1, gate1, shift2, scale2, gate2 = modulation
        x = x + (1.0 + gate1) * self.attn(self.norm1(x) * (1.0 + scale1) + shift1, bias, prefix)
        return x + (1.0 + gate2) * self.ff(self.norm2(x) * (1.0 + scale2) + shift2)

    def zero_residual(self) -> None:
        """Make the layer the identity (attention and feed-forward add zero), so a layer
        added to a trained stack starts from what the stack computed; the zero output
        projections still get gradients, and through them the rest of the layer."""
        for linear in (self.attn.out, self.ff[2]):
            nn.init.zeros_(linear.weight)
            nn.init.zeros_(linear.bias)

    def forward_keeping_keys_values(self, x: Tensor, bias: Tensor) -> tuple[Tensor, KeysValues]:
        """The layer's output and the keys and values its attention computed."""
        q, k, v = self.attn.project(self.norm1(x))
        x = x + self.attn.attend(q, k, v, bias)
        return x + self.ff(self.norm2(x)), (k, v)


class TransformerStack(nn.Module):
    """``layers`` pre-norm layers and a final LayerNorm."""

    def __init__(self, width: int, layers: int, heads: int, ff_width: int) -> None:
        super().__init__()
        self.layers = nn.ModuleList(EncoderLayer(width, heads, ff_width) for _ in range(layers))
        self.norm = nn.LayerNorm(width)

    def forward(
        self,
        x: Tensor,
        bias: Tensor,
        prefixes: Sequence[KeysValues] | None = None,
        modulations: Sequence[Modulation] | None = None,
    ) -> Tensor:
        """``prefixes``: one ``prefix`` per layer (``SelfAttention.forward``), or none;
        ``modulations``: one per layer (``EncoderLayer.forward``), or none."""
        for index, layer in enumerate(self.layers):
            x = layer(
                x,
                bias,
                None if prefixes is None else prefixes[index],
                None if modulations is None else modulations[index],
            )
        return self.norm(x)

    def keys_values(self, x: Tensor, bias: Tensor) -> list[KeysValues]:
        """The keys and values every layer computes for the tokens ``x`` attending among
        themselves: what ``forward``'s ``prefixes`` takes for a block that attends to nothing
        else."""
        out: list[KeysValues] = []
        for index, layer in enumerate(self.layers):
            if index + 1 == len(self.layers):
                # The last layer's output is not needed, only what its attention saw.
                _, k, v = layer.attn.project(layer.norm1(x))
                out.append((k, v))
            else:
                x, keys_values = layer.forward_keeping_keys_values(x, bias)
                out.append(keys_values)
        return out


class ConditionModulation(nn.Module):
    """Shift, scale and gate of every layer's attention and feed-forward from one
    conditioning vector per row (DiT's adaLN, as deltas: ``(1 + scale)``, ``(1 + gate)``).
    The projection starts at zero, so a stack given these modulations computes what it did
    without them until training moves them."""

    def __init__(self, width: int, layers: int) -> None:
        super().__init__()
        self.layers = layers
        self.proj = nn.Linear(width, 6 * layers * width)
        nn.init.zeros_(self.proj.weight)
        nn.init.zeros_(self.proj.bias)

    def forward(self, condition: Tensor, token_weight: Tensor | None = None) -> list[Modulation]:
        """``condition`` [B, W] -> one modulation per layer, each part [B, 1, W], or
        [B, S, W] times ``token_weight`` [S] (0: that token is left unmodulated)."""
        parts = self.proj(F.silu(condition)).unsqueeze(1)
        if token_weight is not None:
            parts = parts * token_weight[None, :, None]
        chunks = parts.chunk(6 * self.layers, dim=-1)
        return [cast(Modulation, tuple(chunks[6 * i : 6 * i + 6])) for i in range(self.layers)]
