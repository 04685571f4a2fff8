"""Rotation and forward-kinematics helpers in torch (float32), shared by losses and sampler.

Conventions (design.md section 4): 6D = the first two columns of the 3x3 world rotation,
column-major ``(r00, r10, r20, r01, r11, r21)``; back to a matrix by Gram-Schmidt with the
third column the cross product. Rotations are global (world) per joint, so forward kinematics
needs no chain of products: ``pos[j] = pos[parent] + R_world[parent] @ offset[j]``.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor

EPS = 1e-8


def rot6d_to_matrix(rot6d: Tensor) -> Tensor:
    """[..., 6] -> [..., 3, 3] by Gram-Schmidt (columns b1, b2, b1 x b2)."""
    a1 = rot6d[..., 0:3]
    a2 = rot6d[..., 3:6]
    b1 = a1 / torch.sqrt((a1 * a1).sum(-1, keepdim=True) + EPS)
    a2 = a2 - (b1 * a2).sum(-1, keepdim=True) * b1
    b2 = a2 / torch.sqrt((a2 * a2).sum(-1, keepdim=True) + EPS)
    b3 = torch.linalg.cross(b1, b2, dim=-1)
    return torch.stack((b1, b2, b3), dim=-1)


def matrix_to_rot6d(matrix: Tensor) -> Tensor:
    """[..., 3, 3] -> [..., 6]: first column then second column."""
    return torch.cat((matrix[..., :, 0], matrix[..., :, 1]), dim=-1)


def global_to_local(global_rot: Tensor, parents: Sequence[int]) -> Tensor:
    """World rotations [..., J, 3, 3] -> parent-relative rotations ``R_parent^T R_j``."""
    local = [global_rot[..., 0, :, :]]
    for j in range(1, len(parents)):
        parent = global_rot[..., parents[j], :, :]
        local.append(parent.transpose(-1, -2) @ global_rot[..., j, :, :])
    return torch.stack(local, dim=-3)


def fk_world(
    global_rot: Tensor, root_pos: Tensor, offsets: Tensor, parents: Sequence[int]
) -> Tensor:
    """World joint positions [..., J, 3] from world rotations [..., J, 3, 3] and root [..., 3]."""
    positions = [root_pos]
    for j in range(1, len(parents)):
        p = parents[j]
        bone = (global_rot[..., p, :, :] @ offsets[j].to(global_rot.dtype).unsqueeze(-1))[..., 0]
        positions.append(positions[p] + bone)
    return torch.stack(positions, dim=-2)


def heading_rotation(cos_psi: Tensor, sin_psi: Tensor) -> Tensor:
    """Rotation about +Y by psi as [..., 3, 3] (psi = 0 faces +Z)."""
    zeros = torch.zeros_like(cos_psi)
    ones = torch.ones_like(cos_psi)
    rows = (
        torch.stack((cos_psi, zeros, sin_psi), dim=-1),
        torch.stack((zeros, ones, zeros), dim=-1),
        torch.stack((-sin_psi, zeros, cos_psi), dim=-1),
    )
    return torch.stack(rows, dim=-2)
