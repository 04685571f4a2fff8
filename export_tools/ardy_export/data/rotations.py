"""Rotation helpers (numpy, batched over any leading axes).

Conventions used across the project:

* Rotation matrices act on column vectors: ``v_world = R @ v_local``.
* Quaternions are ``(w, x, y, z)``, unit length.
* The 6D rotation representation is the first two columns of the matrix, column-major:
  ``(r00, r10, r20, r01, r11, r21)``; the inverse is Gram-Schmidt on the two columns with the
  third column their cross product (design.md section 4).
* Yaw is a rotation about +Y; ``yaw_matrix(a)`` turns +Z towards +X, so a heading
  ``psi = atan2(forward.x, forward.z)`` grows by ``a``.

Euler angles are only ever converted to matrices, never interpolated.
"""

from __future__ import annotations

import numpy as np

_AXES = {"X": 0, "Y": 1, "Z": 2}


def axis_rotation(axis: str, angles: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] about one of the coordinate axes by ``angles`` (radians)."""
    angles = np.asarray(angles, dtype=np.float64)
    c = np.cos(angles)
    s = np.sin(angles)
    one = np.ones_like(angles)
    zero = np.zeros_like(angles)
    if axis == "X":
        rows = ((one, zero, zero), (zero, c, -s), (zero, s, c))
    elif axis == "Y":
        rows = ((c, zero, s), (zero, one, zero), (-s, zero, c))
    elif axis == "Z":
        rows = ((c, -s, zero), (s, c, zero), (zero, zero, one))
    else:
        raise ValueError(f"unknown rotation axis {axis!r} (expected X, Y or Z)")
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def euler_to_matrix(angles: np.ndarray, order: str) -> np.ndarray:
    """Matrices [..., 3, 3] from Euler angles [..., 3] in radians.

    ``order`` names the axes in the order the angles are given (e.g. ``"ZXY"`` for a BVH
    channel list ``Zrotation Xrotation Yrotation``); the matrix is the product in that order,
    ``R = R_Z(a0) @ R_X(a1) @ R_Y(a2)``, the BVH convention (the last axis acts first).
    """
    if len(order) != 3 or any(axis not in _AXES for axis in order):
        raise ValueError(f"bad Euler order {order!r}: expected three of X, Y, Z")
    angles = np.asarray(angles, dtype=np.float64)
    result = axis_rotation(order[0], angles[..., 0])
    for k in (1, 2):
        result = result @ axis_rotation(order[k], angles[..., k])
    return result


def yaw_matrix(angles: np.ndarray | float) -> np.ndarray:
    """Rotation matrices [..., 3, 3] about +Y by ``angles`` (radians)."""
    return axis_rotation("Y", np.asarray(angles, dtype=np.float64))


def matrix_to_quaternion(matrices: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) [..., 4] from rotation matrices [..., 3, 3], w >= 0."""
    m = np.asarray(matrices, dtype=np.float64)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    # Four candidate solutions; take the numerically best (largest denominator) per element.
    candidates = np.stack(
        [
            np.stack([1.0 + m00 + m11 + m22, m21 - m12, m02 - m20, m10 - m01], axis=-1),
            np.stack([m21 - m12, 1.0 + m00 - m11 - m22, m01 + m10, m02 + m20], axis=-1),
            np.stack([m02 - m20, m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21], axis=-1),
            np.stack([m10 - m01, m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22], axis=-1),
        ],
        axis=-2,
    )
    diag = np.stack(
        [
            1.0 + m00 + m11 + m22,
            1.0 + m00 - m11 - m22,
            1.0 - m00 + m11 - m22,
            1.0 - m00 - m11 + m22,
        ],
        axis=-1,
    )
    best = np.argmax(diag, axis=-1)
    quat = np.take_along_axis(candidates, best[..., None, None], axis=-2)[..., 0, :]
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    return np.where(quat[..., :1] < 0.0, -quat, quat)


def quaternion_to_matrix(quaternions: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] from quaternions (w, x, y, z) [..., 4] (normalized here)."""
    q = np.asarray(quaternions, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def quaternion_slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Spherical interpolation [..., 4] along the shorter arc; ``t`` broadcasts to [...]."""
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.clip(np.abs(dot), 0.0, 1.0)
    theta = np.arccos(dot)
    sin_theta = np.sin(theta)
    small = sin_theta < 1e-6
    safe = np.where(small, 1.0, sin_theta)
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(small, t, np.sin(t * theta) / safe)
    out = w0 * q0 + w1 * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def slerp_matrices(r0: np.ndarray, r1: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Slerp between rotation matrices [..., 3, 3] (through quaternions)."""
    return quaternion_to_matrix(
        quaternion_slerp(matrix_to_quaternion(r0), matrix_to_quaternion(r1), t)
    )


def rot6d_from_matrix(matrices: np.ndarray) -> np.ndarray:
    """6D [..., 6]: the first two columns, column-major (r00, r10, r20, r01, r11, r21)."""
    m = np.asarray(matrices)
    return np.concatenate([m[..., :, 0], m[..., :, 1]], axis=-1)


def matrix_from_rot6d(rot6d: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] from 6D [..., 6]: Gram-Schmidt, third column = cross."""
    x = np.asarray(rot6d, dtype=np.float64)
    a = x[..., 0:3]
    b = x[..., 3:6]
    c0 = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
    b = b - np.sum(c0 * b, axis=-1, keepdims=True) * c0
    c1 = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
    c2 = np.cross(c0, c1)
    return np.stack([c0, c1, c2], axis=-1)


def project_to_rotation(matrices: np.ndarray) -> np.ndarray:
    """The nearest proper rotation [..., 3, 3] to each matrix (SVD, determinant fixed to +1)."""
    u, _, vt = np.linalg.svd(np.asarray(matrices, dtype=np.float64))
    det = np.linalg.det(u @ vt)
    fix = np.ones(u.shape[:-1])
    fix[..., -1] = det
    return (u * fix[..., None, :]) @ vt


def rotation_angle(matrices: np.ndarray) -> np.ndarray:
    """Rotation angle (radians) [...] of each matrix [..., 3, 3]."""
    m = np.asarray(matrices, dtype=np.float64)
    trace = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    return np.arccos(np.clip((trace - 1.0) * 0.5, -1.0, 1.0))


def matrix_to_euler(matrices: np.ndarray, order: str) -> np.ndarray:
    """Euler angles [..., 3] (radians, in ``order``) with ``euler_to_matrix(angles, order) == R``.

    Works for the six Tait-Bryan orders; in gimbal lock the last angle is set to zero.
    """
    if len(order) != 3 or sorted(order) != ["X", "Y", "Z"]:
        raise ValueError(f"bad Euler order {order!r}: expected a permutation of XYZ")
    i, j, k = (_AXES[axis] for axis in order)
    parity = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    m = np.asarray(matrices, dtype=np.float64)
    sin_b = np.clip(parity * m[..., i, k], -1.0, 1.0)
    b = np.arcsin(sin_b)
    locked = np.abs(sin_b) > 1.0 - 1e-9
    a = np.arctan2(-parity * m[..., j, k], m[..., k, k])
    c = np.arctan2(-parity * m[..., i, j], m[..., i, i])
    a_locked = np.arctan2(parity * m[..., k, j], m[..., j, j])
    a = np.where(locked, a_locked, a)
    c = np.where(locked, 0.0, c)
    return np.stack([a, b, c], axis=-1)
