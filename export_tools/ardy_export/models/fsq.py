"""Finite scalar quantization (Mentzer et al. 2023) with a straight-through gradient.

Each latent dimension ``i`` with ``l_i`` levels is bounded by a shifted tanh, rounded to an
integer and scaled into [-1, 1]:

    half_l = (l - 1) * (1 - 1e-3) / 2
    offset = 0.5 if l is even else 0
    shift  = atanh(offset / half_l)
    code   = round(tanh(z + shift) * half_l - offset) / (l // 2)

so the codes are ``k / (l // 2)`` for the ``l`` integers ``k`` in
``[-(l // 2), (l - 1) // 2]``. Rounding is half-to-even (torch.round and ONNX Round agree).
In training the gradient passes through the rounding unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn


def round_ste(x: Tensor) -> Tensor:
    """Round with a straight-through (identity) gradient."""
    return x + (torch.round(x) - x).detach()


class FSQ(nn.Module):
    def __init__(self, levels: Sequence[int]) -> None:
        super().__init__()
        if not levels or min(levels) < 2:
            raise ValueError(f"FSQ levels must be >= 2 per dimension, got {list(levels)}")
        lv = torch.tensor(list(levels), dtype=torch.float64)
        half_l = (lv - 1.0) * (1.0 - 1e-3) / 2.0
        offset = torch.where(lv.remainder(2) == 0, 0.5, 0.0).to(torch.float64)
        shift = torch.atanh(offset / half_l)
        self.levels = [int(v) for v in levels]
        self.register_buffer("half_l", half_l.float(), persistent=False)
        self.register_buffer("offset", offset.float(), persistent=False)
        self.register_buffer("shift", shift.float(), persistent=False)
        self.register_buffer("half_width", torch.floor(lv / 2.0).float(), persistent=False)

    @property
    def dim(self) -> int:
        return len(self.levels)

    def bound(self, z: Tensor) -> Tensor:
        return torch.tanh(z + self.shift) * self.half_l - self.offset

    def forward(self, z: Tensor) -> Tensor:
        return round_ste(self.bound(z)) / self.half_width

    def codes_to_indices(self, codes: Tensor) -> Tensor:
        """Integer level index 0..l-1 per dimension (for tests and statistics)."""
        return torch.round(codes * self.half_width + self.half_width).long()
