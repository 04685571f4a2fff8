"""World-space constraints and their per-window conversion into goal tensors (design.md 8).

Pure functions of their inputs (numpy, no torch, no model), written to be ported line by
line to the C++ runtime's ``constraints`` module.

Constraint kinds (frames are model frames at the package's fps, counted from the start of
the rollout; positions in metres, world space, Y up):

* ``RootWaypoint(frame, x, z, heading=None)``: the Hips ground position (x, z) at a frame,
  optionally the heading psi (radians, 0 faces +Z) -> goal features p.x, p.z (and cos psi,
  sin psi).
* ``RootPath(start_frame, positions [K, 2], headings [K] or None)``: a dense path, one
  (x, z) per frame from ``start_frame``; ``path_from_polyline`` makes one from waypoints
  and a speed.
* ``PoseKeyframe(frame, features [M])``: a full-body pose given as world-space explicit
  features (``pose_features`` computes them from world rotations and positions); root
  (unless ``include_root`` is False), 6D rotations and joint positions J are constrained,
  velocities and contacts are not.
* ``JointTarget(frame, joint, position=None, rotation=None)``: ``rotation`` [3, 3] is the
  joint's world rotation (its 6D goes in); ``position`` [3] is, for the root joint (0), the
  world position of the Hips (p.x, p.y, p.z), and for any other joint its position relative
  to the Hips' ground projection, exactly the J feature (world position minus (p.x, 0, p.z):
  height absolute, no heading rotation). A world-space hand target therefore needs the root
  position of that frame; ``JointTarget.from_world`` makes the relative target from it.
* ``FootContact(start_frame, end_frame, feet, value=1.0)``: contact labels (0 or 1) of the
  given feet (indices into Foot_L, Toes_L, Foot_R, Toes_R) over frames [start, end).

Per window (``window_goals``): the frames [s, s + (C + F_limit) * P) are rasterized into an
explicit goal ``g`` and mask ``v`` [frames, M] (later constraints in the list override earlier
ones on the same entries), root x and z goals are re-centered by subtracting the window's
offset (the world x, z that the model's origin stands for), constrained entries are
normalized ``(g - mean) / std`` and unconstrained ones set to 0, and the result is patchified
(token k holds frames kP..kP+P-1, frame-major, M features each). The first C tokens are the
in-window goals; the next ones are future goals, cut after the last future token with any
constrained entry (F = 0 when none). Frames before s are passed (dropped); frames at or after
s + (C + F_limit) * P wait for a later window.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ardy_export.models import layout as L


@dataclass(frozen=True)
class RootWaypoint:
    frame: int
    x: float
    z: float
    heading: float | None = None


@dataclass(frozen=True)
class RootPath:
    start_frame: int
    positions: np.ndarray  # [K, 2] (x, z), one per frame
    headings: np.ndarray | None = None  # [K] radians


@dataclass(frozen=True)
class PoseKeyframe:
    frame: int
    features: np.ndarray  # [M] world-space explicit features
    include_root: bool = True


@dataclass(frozen=True)
class JointTarget:
    frame: int
    joint: int
    position: np.ndarray | None = None  # [3], see the module docstring
    rotation: np.ndarray | None = None  # [3, 3] world rotation

    @classmethod
    def from_world(
        cls,
        frame: int,
        joint: int,
        world_position: Sequence[float],
        root_xz: Sequence[float],
        rotation: np.ndarray | None = None,
    ) -> JointTarget:
        """A target from a world position and the Hips' ground position at that frame."""
        rel = np.asarray(world_position, dtype=np.float64).copy()
        rel[0] -= root_xz[0]
        rel[2] -= root_xz[1]
        return cls(frame, joint, rel, rotation)


@dataclass(frozen=True)
class FootContact:
    start_frame: int
    end_frame: int  # exclusive
    feet: tuple[int, ...] = (0, 1, 2, 3)
    value: float = 1.0


Constraint = RootWaypoint | RootPath | PoseKeyframe | JointTarget | FootContact


def constraint_frames(constraint: Constraint) -> tuple[int, int]:
    """First and last frame (inclusive) a constraint touches."""
    if isinstance(constraint, RootPath):
        return constraint.start_frame, constraint.start_frame + len(constraint.positions) - 1
    if isinstance(constraint, FootContact):
        return constraint.start_frame, constraint.end_frame - 1
    return constraint.frame, constraint.frame


def validate(constraint: Constraint, num_joints: int = L.NUM_JOINTS) -> None:
    """Refuse NaN/inf values, bad joints and empty ranges, naming the field."""

    def finite(name: str, value: object) -> None:
        if value is not None and not np.all(np.isfinite(np.asarray(value, dtype=np.float64))):
            raise ValueError(f"{type(constraint).__name__}.{name} holds NaN or infinity")

    for name in ("x", "z", "heading", "positions", "headings", "features", "position", "rotation"):
        finite(name, getattr(constraint, name, None))
    if isinstance(constraint, JointTarget) and not 0 <= constraint.joint < num_joints:
        raise ValueError(f"JointTarget.joint {constraint.joint} is not in 0..{num_joints - 1}")
    if isinstance(constraint, RootPath):
        if constraint.positions.ndim != 2 or constraint.positions.shape[1] != 2:
            raise ValueError(f"RootPath.positions must be [K, 2], got {constraint.positions.shape}")
        if constraint.headings is not None and len(constraint.headings) != len(
            constraint.positions
        ):
            raise ValueError("RootPath.headings must have one entry per position")
    if isinstance(constraint, FootContact) and constraint.end_frame <= constraint.start_frame:
        raise ValueError("FootContact.end_frame must be greater than start_frame")


def rasterize(
    constraints: Sequence[Constraint], first_frame: int, num_frames: int
) -> tuple[np.ndarray, np.ndarray]:
    """Explicit world-space goal and mask [num_frames, M] (float64) for frames
    [first_frame, first_frame + num_frames)."""
    m = L.FEATURE_SIZE
    goal = np.zeros((num_frames, m), dtype=np.float64)
    mask = np.zeros((num_frames, m), dtype=np.float64)

    def put(frame: int, sl: slice | list[int], values: Sequence[float] | np.ndarray) -> None:
        i = frame - first_frame
        if 0 <= i < num_frames:
            goal[i, sl] = values
            mask[i, sl] = 1.0

    for c in constraints:
        if isinstance(c, RootWaypoint):
            put(c.frame, [0, 2], (c.x, c.z))
            if c.heading is not None:
                put(c.frame, L.HEADING_SLICE, (np.cos(c.heading), np.sin(c.heading)))
        elif isinstance(c, RootPath):
            for k in range(len(c.positions)):
                f = c.start_frame + k
                put(f, [0, 2], c.positions[k])
                if c.headings is not None:
                    put(f, L.HEADING_SLICE, (np.cos(c.headings[k]), np.sin(c.headings[k])))
        elif isinstance(c, PoseKeyframe):
            if c.include_root:
                put(c.frame, L.ROOT_SLICE, c.features[L.ROOT_SLICE])
            put(c.frame, L.ROT6D_SLICE, c.features[L.ROT6D_SLICE])
            put(c.frame, L.JOINT_POS_SLICE, c.features[L.JOINT_POS_SLICE])
        elif isinstance(c, JointTarget):
            if c.position is not None:
                if c.joint == 0:
                    put(c.frame, L.POS_SLICE, c.position)
                else:
                    put(c.frame, L.joint_pos_slice(c.joint), c.position)
            if c.rotation is not None:
                rot = np.asarray(c.rotation, dtype=np.float64)
                put(c.frame, L.rot6d_slice(c.joint), np.concatenate((rot[:, 0], rot[:, 1])))
        elif isinstance(c, FootContact):
            cols = [L.CONTACT_SLICE.start + foot for foot in c.feet]
            for f in range(c.start_frame, c.end_frame):
                put(f, cols, [c.value] * len(cols))
        else:  # pragma: no cover - guarded by the type
            raise TypeError(f"unknown constraint type {type(c).__name__}")
    return goal, mask


@dataclass(frozen=True)
class WindowGoals:
    """Goal tensors of one window, normalized and patchified (float32)."""

    window_goal: np.ndarray  # [C, P*M]
    window_goal_mask: np.ndarray  # [C, P*M]
    future_goal: np.ndarray  # [F, P*M]
    future_goal_mask: np.ndarray  # [F, P*M]
    future_mask: np.ndarray  # [F]

    @property
    def has_constraints(self) -> bool:
        return bool(self.window_goal_mask.any() or self.future_mask.any())

    @property
    def root_path_only(self) -> bool:
        """A dense root path and nothing else: the root's x and z are given on at least half
        of the window's frames and every constrained entry (window and future) is a root
        position or heading (src/constraints.hpp ``WindowGoals::root_path_only``)."""
        window = self.window_goal_mask.reshape(-1, L.FEATURE_SIZE)
        future = self.future_goal_mask.reshape(-1, L.FEATURE_SIZE)
        root_end = L.HEADING_SLICE.stop
        if window[:, root_end:].any() or future[:, root_end:].any():
            return False
        path_frames = int(np.count_nonzero((window[:, 0] > 0) & (window[:, 2] > 0)))
        return 2 * path_frames >= window.shape[0]

    @property
    def future_tokens(self) -> int:
        return int(self.future_mask.shape[0])


def interpolate_root(goal: np.ndarray, mask: np.ndarray, anchor_xz: Sequence[float]) -> None:
    """Fills the root's x and z between sparse root targets, in place: linear from
    ``anchor_xz`` (the root of the frame before the first) to the first target, then between
    consecutive targets (src/constraints.hpp GoalSpec::interpolate_root)."""
    previous, start = -1, np.asarray(anchor_xz, dtype=np.float64)
    for f in np.flatnonzero((mask[:, 0] > 0.0) & (mask[:, 2] > 0.0)):
        target = goal[f, [0, 2]].copy()
        for k in range(previous + 1, f):
            a = (k - previous) / (f - previous)
            goal[k, [0, 2]] = start + a * (target - start)
            mask[k, [0, 2]] = 1.0
        previous, start = int(f), target


def limit_root_speed(
    goal: np.ndarray, mask: np.ndarray, anchor_xz: Sequence[float], max_step: float
) -> None:
    """Pulls root (x, z) targets that would need more than ``max_step`` metres per frame
    (from the previous target, or ``anchor_xz`` before the first) back toward the previous
    one, in place (src/constraints.hpp GoalSpec::max_root_speed)."""
    previous, start = -1, np.asarray(anchor_xz, dtype=np.float64)
    for f in np.flatnonzero((mask[:, 0] > 0.0) & (mask[:, 2] > 0.0)):
        target = goal[f, [0, 2]].copy()
        allowed = max_step * (f - previous)
        distance = float(np.linalg.norm(target - start))
        if distance > allowed:
            target = start + (target - start) * (allowed / distance)
        goal[f, [0, 2]] = target
        previous, start = int(f), target


def window_goals(
    constraints: Sequence[Constraint],
    window_start: int,
    offset_xz: Sequence[float],
    mean: np.ndarray,
    std: np.ndarray,
    window_tokens: int,
    future_limit_tokens: int,
    patch: int = L.PATCH,
    interpolate: bool = False,
    max_root_step: float = 0.0,
) -> WindowGoals:
    """Convert world-space constraints into one window's goal tensors (module docstring);
    ``interpolate`` first turns sparse root targets into a path (``interpolate_root``), then
    ``max_root_step`` (metres per frame; 0: none) limits the root's speed (``limit_root_speed``)."""
    tokens = window_tokens + future_limit_tokens
    frames = tokens * patch
    goal, mask = rasterize(constraints, window_start, frames)
    if interpolate:
        interpolate_root(goal, mask, offset_xz)
    if max_root_step > 0.0:
        limit_root_speed(goal, mask, offset_xz, max_root_step)
    goal[:, 0] -= offset_xz[0]
    goal[:, 2] -= offset_xz[1]
    norm = (goal - np.asarray(mean, dtype=np.float64)) / np.asarray(std, dtype=np.float64)
    norm = np.where(mask > 0.0, norm, 0.0)
    m = goal.shape[1]
    g = norm.astype(np.float32).reshape(tokens, patch * m)
    v = mask.astype(np.float32).reshape(tokens, patch * m)
    future_any = v[window_tokens:].any(axis=1)
    count = int(np.nonzero(future_any)[0][-1]) + 1 if future_any.any() else 0
    end = window_tokens + count
    return WindowGoals(
        window_goal=g[:window_tokens],
        window_goal_mask=v[:window_tokens],
        future_goal=g[window_tokens:end],
        future_goal_mask=v[window_tokens:end],
        future_mask=future_any[:count].astype(np.float32),
    )


def split_by_time(
    constraints: Sequence[Constraint], window_start: int, horizon_frames: int
) -> tuple[list[Constraint], list[Constraint], list[Constraint]]:
    """(passed, active, waiting): entirely before ``window_start``; touching
    [window_start, window_start + horizon_frames); entirely at or after its end."""
    passed: list[Constraint] = []
    active: list[Constraint] = []
    waiting: list[Constraint] = []
    end = window_start + horizon_frames
    for c in constraints:
        first, last = constraint_frames(c)
        if last < window_start:
            passed.append(c)
        elif first >= end:
            waiting.append(c)
        else:
            active.append(c)
    return passed, active, waiting


def heading_from_positions(positions: np.ndarray) -> float:
    """psi = atan2(forward.x, forward.z), forward = up x right, right = hip_R - hip_L (xz)."""
    right = positions[L.RIGHT_HIP] - positions[L.LEFT_HIP]
    return float(np.arctan2(right[2], -right[0]))


def pose_features(global_rotations: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """World explicit features [M] of one pose (velocities and contacts left at 0).

    global_rotations [J, 3, 3], positions [J, 3] world (positions[0] = Hips).
    """
    feat = np.zeros(L.FEATURE_SIZE, dtype=np.float64)
    p = positions[0]
    psi = heading_from_positions(positions)
    feat[L.POS_SLICE] = p
    feat[L.HEADING_SLICE] = (np.cos(psi), np.sin(psi))
    rot = np.asarray(global_rotations, dtype=np.float64)
    feat[L.ROT6D_SLICE] = np.concatenate((rot[:, :, 0], rot[:, :, 1]), axis=1).reshape(-1)
    rel = positions[1:] - np.array([p[0], 0.0, p[2]])
    feat[L.JOINT_POS_SLICE] = rel.reshape(-1)
    return feat


def path_from_polyline(
    points: Sequence[Sequence[float]],
    speed: float,
    start_frame: int,
    fps: float = L.FPS,
    with_heading: bool = True,
) -> RootPath:
    """A dense path at constant ``speed`` (m/s) along a polyline of (x, z) points, one sample
    per frame from ``start_frame`` to the last point; headings along the direction of travel."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2 or speed <= 0.0:
        raise ValueError("path_from_polyline needs >= 2 points [K, 2] and a positive speed")
    seg = np.diff(pts, axis=0)
    lengths = np.linalg.norm(seg, axis=1)
    cum = np.concatenate(([0.0], np.cumsum(lengths)))
    count = int(np.floor(cum[-1] / speed * fps)) + 1
    dist = np.arange(count) * speed / fps
    xs = np.interp(dist, cum, pts[:, 0])
    zs = np.interp(dist, cum, pts[:, 1])
    headings = None
    if with_heading:
        idx = np.clip(np.searchsorted(cum, dist, side="right") - 1, 0, len(seg) - 1)
        headings = np.arctan2(seg[idx, 0], seg[idx, 1])
    return RootPath(start_frame, np.stack((xs, zs), axis=1), headings)
