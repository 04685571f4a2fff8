"""DDPM training and deterministic DDIM sampling with x0 prediction (design.md section 5).

The schedule is a plain array ``alphas_cumprod`` [N] (float64 here, written to model.json):
``alphas_cumprod[t]`` is the signal fraction of noise level ``t`` in 0..N-1, t = N-1 the
noisiest. Training draws t uniformly and forms

    x_t = sqrt(ab[t]) * x0 + sqrt(1 - ab[t]) * eps,   eps ~ N(0, I)

and the model predicts x0. Sampling with S steps (1 <= S <= N) visits the timesteps of
``ddim_timesteps(N, S)``; from x_T = noise (standard normal), at each visited t_i:

    x0   = model(x_t, t_i)                          (guidance and root overwrite applied)
    if i is the last step: stop, the result is x0
    eps  = (x_t - a_i * x0) / b_i                   a_i = sqrt(ab[t_i]), b_i = sqrt(1 - ab[t_i])
    x_t' = a_j * x0 + b_j * eps                     j = i + 1

with a, b computed in float64 from ``alphas_cumprod`` and rounded to float32 before use;
all tensor arithmetic is float32 in the order written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor


def cosine_alphas_cumprod(steps: int, s: float = 0.008, max_beta: float = 0.999) -> np.ndarray:
    """Cosine schedule (Nichol and Dhariwal 2021) discretized to ``steps`` noise levels."""
    if steps < 1:
        raise ValueError(f"diffusion steps must be >= 1, got {steps}")

    def f(t: float) -> float:
        return math.cos((t + s) / (1.0 + s) * math.pi / 2.0) ** 2

    ab = []
    prod = 1.0
    for i in range(steps):
        beta = min(1.0 - f((i + 1) / steps) / f(i / steps), max_beta)
        prod *= 1.0 - beta
        ab.append(prod)
    return np.asarray(ab, dtype=np.float64)


def ddim_timesteps(num_train_steps: int, num_sample_steps: int) -> list[int]:
    """The timesteps a DDIM run with S steps visits, noisiest first.

    ``t_i = ((N - 1) * (S - 1 - i) * 2 + (S - 1)) // (2 * (S - 1))`` for i = 0..S-1 (N - 1
    and 0 rounded evenly between, integer arithmetic, ties rounded up); for S = 1 the only
    step is N - 1. Examples: N = 10, S = 4 -> [9, 6, 3, 0]; S = 10 -> [9, 8, ..., 0].
    """
    n, s = num_train_steps, num_sample_steps
    if not 1 <= s <= n:
        raise ValueError(f"DDIM steps must be in 1..{n}, got {s}")
    if s == 1:
        return [n - 1]
    return [((n - 1) * (s - 1 - i) * 2 + (s - 1)) // (2 * (s - 1)) for i in range(s)]


@dataclass(frozen=True)
class DiffusionSchedule:
    alphas_cumprod: np.ndarray  # [N] float64

    @classmethod
    def cosine(cls, steps: int = 10) -> DiffusionSchedule:
        return cls(cosine_alphas_cumprod(steps))

    @property
    def num_steps(self) -> int:
        return int(self.alphas_cumprod.shape[0])

    def coefficients(self, t: int) -> tuple[float, float]:
        """(sqrt(ab[t]), sqrt(1 - ab[t])) rounded to float32."""
        ab = float(self.alphas_cumprod[t])
        return float(np.float32(math.sqrt(ab))), float(np.float32(math.sqrt(1.0 - ab)))

    def q_sample(self, x0: Tensor, t: Tensor, noise: Tensor) -> Tensor:
        """Forward noising of a batch; t [B] int64."""
        ab = torch.as_tensor(self.alphas_cumprod, dtype=torch.float64, device=x0.device)[t]
        a = torch.sqrt(ab).to(x0.dtype)
        b = torch.sqrt(1.0 - ab).to(x0.dtype)
        shape = (-1,) + (1,) * (x0.dim() - 1)
        return a.reshape(shape) * x0 + b.reshape(shape) * noise

    def ddim_step(self, x_t: Tensor, x0: Tensor, t: int, t_next: int) -> Tensor:
        """One deterministic DDIM update (eta = 0) from timestep t to t_next < t."""
        a, b = self.coefficients(t)
        a_n, b_n = self.coefficients(t_next)
        eps = (x_t - a * x0) / b
        return a_n * x0 + b_n * eps

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "ddpm_cosine",
            "num_steps": self.num_steps,
            "alphas_cumprod": [float(v) for v in self.alphas_cumprod],
            "prediction": "x0",
            "sampler": "ddim_eta0",
            "timestep_rule": "t_i = ((N-1)*(S-1-i)*2 + (S-1)) // (2*(S-1)); S=1: [N-1]",
        }

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> DiffusionSchedule:
        return cls(np.asarray(values["alphas_cumprod"], dtype=np.float64))
