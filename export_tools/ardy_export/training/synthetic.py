"""A tiny generator of plausible synthetic motion in the exact feature layout (design.md 4).

For unit tests and for developing without the BVH data: a 21-joint upright skeleton walks,
runs, turns, waves or raises its hands with sinusoidal joint rotations, and the features
(root, heading, 6D world rotations, planar-relative joint positions, velocities, contacts)
are computed from the resulting world rotations and FK positions exactly as the data
pipeline defines them, so FK consistency holds and every label moves differently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ardy_export.models import layout as L
from ardy_export.models.layout import Skeleton

CONTENTS: tuple[str, ...] = (
    "walk",
    "run",
    "walk-turn-left",
    "walk-turn-right",
    "wave-right-hand",
    "raise-up-both-hands",
)
STYLES: tuple[str, ...] = ("normal", "elderly", "active")


def synthetic_skeleton() -> Skeleton:
    """Upright T-pose facing +Z, left side +X (the model skeleton's conventions)."""
    o = np.zeros((L.NUM_JOINTS, 3), dtype=np.float32)
    idx = {n: i for i, n in enumerate(L.JOINT_NAMES)}

    def put(name: str, value: tuple[float, float, float]) -> None:
        o[idx[name]] = value

    put("Spine", (0.0, 0.10, 0.0))
    put("Chest", (0.0, 0.15, 0.0))
    put("Neck", (0.0, 0.25, 0.0))
    put("Head", (0.0, 0.10, 0.0))
    for side, sx in (("L", 1.0), ("R", -1.0)):
        put(f"Shoulder_{side}", (0.05 * sx, 0.20, 0.0))
        put(f"UpperArm_{side}", (0.12 * sx, 0.0, 0.0))
        put(f"LowerArm_{side}", (0.28 * sx, 0.0, 0.0))
        put(f"Hand_{side}", (0.25 * sx, 0.0, 0.0))
        put(f"UpperLeg_{side}", (0.09 * sx, -0.05, 0.0))
        put(f"LowerLeg_{side}", (0.0, -0.42, 0.0))
        put(f"Foot_{side}", (0.0, -0.42, 0.0))
        put(f"Toes_{side}", (0.0, -0.05, 0.14))
    return Skeleton(L.JOINT_NAMES, L.PARENTS, o)


def _rx(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack(
        [np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2
    )


def _ry(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack(
        [np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2
    )


def _rz(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack(
        [np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2
    )


def fk_numpy(
    local: np.ndarray, root_pos: np.ndarray, skeleton: Skeleton
) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations [T, J, 3, 3] + root [T, 3] -> (world rotations, world positions)."""
    t, j = local.shape[:2]
    glob = np.zeros_like(local)
    pos = np.zeros((t, j, 3))
    glob[:, 0] = local[:, 0]
    pos[:, 0] = root_pos
    for k in range(1, j):
        p = skeleton.parents[k]
        glob[:, k] = glob[:, p] @ local[:, k]
        pos[:, k] = pos[:, p] + (glob[:, p] @ skeleton.offsets[k].astype(np.float64))
    return glob, pos


def features_from_motion(
    global_rot: np.ndarray, positions: np.ndarray, fps: float = L.FPS
) -> np.ndarray:
    """Features [T, M] in the design.md layout (contacts: height < 0.1 m, speed < 0.5 m/s).

    Equivalent to the data pipeline's function of the same name (used when that package is
    absent); contact thresholds here are fixed.
    """
    t = positions.shape[0]
    vel = np.zeros_like(positions)
    if t > 1:
        vel[1:] = (positions[1:] - positions[:-1]) * fps
        vel[0] = vel[1]
    right = positions[:, L.RIGHT_HIP] - positions[:, L.LEFT_HIP]
    psi = np.arctan2(right[:, 2], -right[:, 0])
    root = positions[:, 0]
    out = np.zeros((t, L.FEATURE_SIZE))
    out[:, L.POS_SLICE] = root
    out[:, L.HEADING_SLICE] = np.stack((np.cos(psi), np.sin(psi)), -1)
    out[:, L.ROT6D_SLICE] = np.concatenate(
        (global_rot[..., :, 0], global_rot[..., :, 1]), -1
    ).reshape(t, -1)
    planar = root * np.array([1.0, 0.0, 1.0])
    out[:, L.JOINT_POS_SLICE] = (positions[:, 1:] - planar[:, None]).reshape(t, -1)
    out[:, L.JOINT_VEL_SLICE] = vel.reshape(t, -1)
    feet = list(L.FOOT_JOINTS)
    height = positions[:, feet, 1]
    speed = np.linalg.norm(vel[:, feet], axis=-1)
    out[:, L.CONTACT_SLICE] = ((height < 0.1) & (speed < 0.5)).astype(np.float64)
    return out.astype(np.float32)


@dataclass
class SyntheticClip:
    name: str
    dataset: str
    content: str
    style: str
    features: np.ndarray  # [T, M] float32


def synthetic_clip(
    content: str,
    style: str,
    seconds: float,
    rng: np.random.Generator,
    skeleton: Skeleton | None = None,
    fps: float = L.FPS,
) -> np.ndarray:
    """Features [T, M] of one synthetic clip."""
    sk = skeleton or synthetic_skeleton()
    n = max(round(seconds * fps), 8)
    t = np.arange(n) / fps
    style_gain = {"normal": 1.0, "elderly": 0.6, "active": 1.3}[style]
    moving = content in ("walk", "run", "walk-turn-left", "walk-turn-right")
    speed = {"run": 3.0}.get(content, 1.2) * style_gain if moving else 0.0
    freq = (1.4 if content == "run" else 0.9) * (0.8 + 0.2 * style_gain)
    turn = {"walk-turn-left": 0.7, "walk-turn-right": -0.7}.get(content, 0.0)
    phase = 2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi)
    amp = (0.5 if content == "run" else 0.35) * min(style_gain, 1.2) if moving else 0.03
    psi = rng.uniform(-np.pi, np.pi) + turn * t
    x0, z0 = rng.uniform(-1.0, 1.0, size=2)
    dx = speed * np.sin(psi) / fps
    dz = speed * np.cos(psi) / fps
    xs = x0 + np.concatenate(([0.0], np.cumsum(dx[:-1])))
    zs = z0 + np.concatenate(([0.0], np.cumsum(dz[:-1])))
    height = 0.93 - (0.04 if content == "run" else 0.02) * np.abs(np.sin(phase)) * (amp > 0.05)
    root_pos = np.stack((xs, height, zs), -1)

    j = sk.num_joints
    idx = {name: i for i, name in enumerate(sk.names)}
    local = np.broadcast_to(np.eye(3), (n, j, 3, 3)).copy()
    lean = 0.15 * (content == "run") + 0.1 * (style == "elderly")
    local[:, 0] = _ry(psi) @ _rx(np.full(n, lean))
    local[:, idx["Spine"]] = _rz(0.05 * amp * np.sin(phase))
    local[:, idx["Neck"]] = _rx(np.full(n, -0.1 * (style == "elderly")))
    for side, sgn, off in (("L", 1.0, 0.0), ("R", -1.0, np.pi)):
        ph = phase + off
        local[:, idx[f"UpperLeg_{side}"]] = _rx(-amp * np.sin(ph))
        local[:, idx[f"LowerLeg_{side}"]] = _rx(amp * 1.2 * np.maximum(0.0, np.sin(ph + 1.2)))
        local[:, idx[f"Foot_{side}"]] = _rx(0.2 * amp * np.cos(ph))
        arm_down = _rz(np.full(n, -sgn * 1.3))
        swing = _rx(0.8 * amp * np.sin(ph + np.pi))
        local[:, idx[f"UpperArm_{side}"]] = arm_down @ swing
        local[:, idx[f"LowerArm_{side}"]] = _rx(np.full(n, -0.3 - 0.3 * amp))
    wave_t = 2 * np.pi * 1.5 * t
    if content in ("wave-right-hand", "raise-up-both-hands"):
        sides = ("R",) if content == "wave-right-hand" else ("L", "R")
        for side in sides:
            sgn = 1.0 if side == "L" else -1.0
            lift = 0.3 if content == "wave-right-hand" else 1.1
            local[:, idx[f"UpperArm_{side}"]] = _rz(np.full(n, sgn * lift * style_gain))
            if content == "wave-right-hand":
                local[:, idx[f"LowerArm_{side}"]] = _rz(sgn * (1.2 + 0.5 * np.sin(wave_t)))
    glob, pos = fk_numpy(local, root_pos, sk)
    return features_from_motion(glob, pos, fps)


def synthetic_clips(
    count: int, seed: int = 0, seconds: tuple[float, float] = (4.0, 8.0)
) -> list[SyntheticClip]:
    """``count`` clips cycling through contents and styles (deterministic for a seed)."""
    rng = np.random.default_rng(seed)
    sk = synthetic_skeleton()
    clips = []
    for i in range(count):
        content = CONTENTS[i % len(CONTENTS)]
        style = STYLES[(i // len(CONTENTS)) % len(STYLES)]
        secs = float(rng.uniform(*seconds))
        feats = synthetic_clip(content, style, secs, rng, sk)
        clips.append(
            SyntheticClip(
                f"synthetic_{content}_{style}_{i:03d}", "synthetic", content, style, feats
            )
        )
    return clips


def rotate_features_yaw(features: np.ndarray, angle: float) -> np.ndarray:
    """Rotate world features [T, M] by ``angle`` about +Y through the origin."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    f = np.asarray(features, dtype=np.float64).copy()
    t = f.shape[0]
    f[:, L.POS_SLICE] = f[:, L.POS_SLICE] @ rot.T
    ch, sh = f[:, 3].copy(), f[:, 4].copy()
    f[:, 3] = ch * c - sh * s
    f[:, 4] = sh * c + ch * s
    r6 = f[:, L.ROT6D_SLICE].reshape(t, L.NUM_JOINTS, 2, 3) @ rot.T
    f[:, L.ROT6D_SLICE] = r6.reshape(t, -1)
    for sl in (L.JOINT_POS_SLICE, L.JOINT_VEL_SLICE):
        f[:, sl] = (f[:, sl].reshape(t, -1, 3) @ rot.T).reshape(t, -1)
    return f.astype(np.float32)
