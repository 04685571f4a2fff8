"""Separated classifier-free guidance: which denoiser rows one window needs, and their sum.

    x0 = D0 + w_text (D_text - D0) + w_con (D_con - D0)
       = (1 - w_text - w_con) D0 + w_text D_text + w_con D_con

D0 sees neither text nor constraints (text_keep = 0, constraint_keep = 0), D_text only the
text (1, 0), D_con only the constraints (0, 1). A window without a prompt counts as
w_text = 0, one without any constraint as w_con = 0. A row whose coefficient is exactly zero
is not evaluated. Rows are always in the order D0, D_text, D_con (skipped ones left out),
and the combination is summed in that order, starting from coefficient * first row.

The text weight may differ in the late steps, those in the lower half of the diffusion
schedule (``is_late_step``): each branch has a ``weight`` for the others and a
``late_weight`` for these, and is evaluated where either is not zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch
from torch import Tensor


@dataclass(frozen=True)
class Branch:
    name: str  # "uncond", "text" or "constraint"
    text_keep: float
    constraint_keep: float
    weight: float  # at the steps in the upper half of the schedule
    late_weight: float  # at the late steps (is_late_step)


def is_late_step(t: int, num_train_steps: int) -> bool:
    """Whether DDIM timestep ``t`` is in the lower half of the schedule."""
    return 2 * t < num_train_steps


def guidance_branches(
    w_text: float,
    w_con: float,
    has_text: bool,
    has_constraints: bool,
    late_w_text: float | None = None,
) -> list[Branch]:
    """The branches of one window; ``late_w_text`` is the text weight of the late steps
    (default: ``w_text``)."""
    wt = float(w_text) if has_text else 0.0
    late_wt = (wt if late_w_text is None else float(late_w_text)) if has_text else 0.0
    wc = float(w_con) if has_constraints else 0.0
    rows = [
        Branch("uncond", 0.0, 0.0, 1.0 - wt - wc, 1.0 - late_wt - wc),
        Branch("text", 1.0, 0.0, wt, late_wt),
        Branch("constraint", 0.0, 1.0, wc, wc),
    ]
    return [b for b in rows if b.weight != 0.0 or b.late_weight != 0.0]


def combine(outputs: Tensor, branches: Sequence[Branch], late: bool = False) -> Tensor:
    """outputs [R, ...] for the R branches in order -> guided x0 [...]; ``late`` picks
    the late steps' weights."""
    if outputs.shape[0] != len(branches):
        raise ValueError(f"{outputs.shape[0]} rows for {len(branches)} branches")
    weights = [b.late_weight if late else b.weight for b in branches]
    result = weights[0] * outputs[0]
    for i in range(1, len(branches)):
        result = result + weights[i] * outputs[i]
    return result


def keep_flags(branches: Sequence[Branch]) -> tuple[Tensor, Tensor]:
    """(text_keep [R], constraint_keep [R]) float32 of the branch rows."""
    return (
        torch.tensor([b.text_keep for b in branches], dtype=torch.float32),
        torch.tensor([b.constraint_keep for b in branches], dtype=torch.float32),
    )
