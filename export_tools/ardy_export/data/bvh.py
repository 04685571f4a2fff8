"""A small BVH reader and writer (numpy only).

The reader is general: any hierarchy, any channel list per joint (positions and rotations in
any order), End Sites kept. Rotation channels become rotation matrices in the order the
CHANNELS line lists them (``Zrotation Xrotation Yrotation`` -> ``R = Rz @ Rx @ Ry``); the
angles themselves are never interpolated. A joint's local translation per frame is its OFFSET
with every position channel it has replacing the matching component (BVH files that carry
position channels on all joints, as the Bandai Namco data does, store the bone vector there).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ardy_export.data.rotations import euler_to_matrix, matrix_to_euler

_POSITION_CHANNELS = {"Xposition": 0, "Yposition": 1, "Zposition": 2}
_ROTATION_CHANNELS = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}


class BvhError(ValueError):
    """A BVH file that cannot be read; the message names the file and what was wrong."""


@dataclass
class BvhJoint:
    name: str
    parent: int  # index into Bvh.joints, -1 for the root
    offset: np.ndarray  # [3], file units
    channels: tuple[str, ...]
    channel_start: int  # first column of this joint's channels in Bvh.motion
    end_site: np.ndarray | None = None  # [3] OFFSET of an End Site child, if any


@dataclass
class Bvh:
    joints: list[BvhJoint]
    frame_time: float
    motion: np.ndarray  # [frames, channels] float64, angles in degrees
    source: str = ""
    _index: dict[str, int] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self._index = {joint.name: i for i, joint in enumerate(self.joints)}

    @property
    def names(self) -> list[str]:
        return [joint.name for joint in self.joints]

    @property
    def parents(self) -> np.ndarray:
        return np.array([joint.parent for joint in self.joints], dtype=np.int64)

    @property
    def offsets(self) -> np.ndarray:
        return np.stack([joint.offset for joint in self.joints])

    @property
    def frame_count(self) -> int:
        return int(self.motion.shape[0])

    @property
    def fps(self) -> float:
        """Frames per second; snapped to the nearest integer when the file's rounded Frame Time
        is within 1e-4 of it (0.0333333 s -> 30 fps)."""
        rate = 1.0 / self.frame_time
        nearest = round(rate)
        return float(nearest) if nearest > 0 and abs(rate - nearest) < 1e-4 * rate else rate

    def joint_index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"{self.source or 'BVH'}: no joint named {name!r}") from None

    def channels_of(self, name: str) -> np.ndarray:
        """The raw channel values [frames, channels] of one joint."""
        joint = self.joints[self.joint_index(name)]
        return self.motion[:, joint.channel_start : joint.channel_start + len(joint.channels)]


def _rotation_order(joint: BvhJoint) -> str:
    return "".join(_ROTATION_CHANNELS[c] for c in joint.channels if c in _ROTATION_CHANNELS)


def parse_bvh(text: str, source: str = "<string>") -> Bvh:
    """Parse BVH text. ``source`` names the file in error messages."""
    head, sep, tail = text.partition("MOTION")
    if not sep:
        raise BvhError(f"{source}: no MOTION section")
    tokens = head.split()
    if not tokens or tokens[0] != "HIERARCHY":
        raise BvhError(f"{source}: the file does not start with HIERARCHY")
    joints: list[BvhJoint] = []
    stack: list[int] = []  # joint index per open brace (-2 marks an End Site)
    pos = 1
    channel_count = 0
    pending: tuple[str, int] | None = None  # (name, parent) of a joint whose brace is next
    current = -1

    def take(n: int) -> list[str]:
        nonlocal pos
        if pos + n > len(tokens):
            raise BvhError(f"{source}: the hierarchy ends early")
        out = tokens[pos : pos + n]
        pos += n
        return out

    while pos < len(tokens):
        word = take(1)[0]
        if word in ("ROOT", "JOINT"):
            (name,) = take(1)
            if word == "ROOT" and stack:
                raise BvhError(f"{source}: ROOT {name} inside another joint")
            parent = stack[-1] if stack else -1
            if parent == -2:
                raise BvhError(f"{source}: joint {name} inside an End Site")
            pending = (name, parent)
        elif word == "End":
            take(1)  # "Site"
            pending = ("", -2)
        elif word == "{":
            if pending is None:
                raise BvhError(f"{source}: unexpected '{{'")
            name, parent = pending
            pending = None
            if parent == -2:
                stack.append(-2)
            else:
                joints.append(BvhJoint(name, parent, np.zeros(3), (), channel_count))
                current = len(joints) - 1
                stack.append(current)
        elif word == "}":
            if not stack:
                raise BvhError(f"{source}: unbalanced '}}'")
            stack.pop()
        elif word == "OFFSET":
            try:
                values = np.array([float(v) for v in take(3)], dtype=np.float64)
            except ValueError as error:
                raise BvhError(f"{source}: bad OFFSET: {error}") from None
            if stack and stack[-1] == -2:
                joints[stack[-2]].end_site = values
            elif stack:
                joints[stack[-1]].offset = values
        elif word == "CHANNELS":
            count_word = take(1)[0]
            try:
                count = int(count_word)
            except ValueError:
                raise BvhError(f"{source}: bad CHANNELS count {count_word!r}") from None
            names = tuple(take(count))
            bad = [n for n in names if n not in _POSITION_CHANNELS and n not in _ROTATION_CHANNELS]
            if bad:
                raise BvhError(f"{source}: unknown channel(s) {bad}")
            if not stack or stack[-1] < 0:
                raise BvhError(f"{source}: CHANNELS outside a joint")
            joint = joints[stack[-1]]
            joint.channels = names
            joint.channel_start = channel_count
            channel_count += count
        else:
            raise BvhError(f"{source}: unexpected word {word!r} in the hierarchy")
    if stack:
        raise BvhError(f"{source}: unbalanced braces in the hierarchy")
    if not joints:
        raise BvhError(f"{source}: no joints")
    for joint in joints:
        rotations = [c for c in joint.channels if c in _ROTATION_CHANNELS]
        if len(rotations) not in (0, 3):
            raise BvhError(f"{source}: joint {joint.name} has {len(rotations)} rotation channels")

    match = re.search(r"Frames:\s*(\d+)\s*Frame Time:\s*([0-9eE.+-]+)", tail)
    if not match:
        raise BvhError(f"{source}: missing 'Frames:' or 'Frame Time:' after MOTION")
    frames = int(match.group(1))
    frame_time = float(match.group(2))
    if not frame_time > 0.0:
        raise BvhError(f"{source}: Frame Time must be positive, found {frame_time}")
    values = np.array(tail[match.end() :].split(), dtype=np.float64)
    if values.size != frames * channel_count:
        raise BvhError(
            f"{source}: expected {frames} frames x {channel_count} channels = "
            f"{frames * channel_count} values, found {values.size}"
        )
    if not np.all(np.isfinite(values)):
        raise BvhError(f"{source}: the motion contains NaN or infinite values")
    motion = values.reshape(frames, channel_count)
    return Bvh(joints=joints, frame_time=frame_time, motion=motion, source=source)


def read_bvh(path: str | Path) -> Bvh:
    """Read and parse a BVH file."""
    path = Path(path)
    return parse_bvh(path.read_text(encoding="utf-8", errors="replace"), source=str(path))


def bvh_local_transforms(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame local rotations [F, J, 3, 3] and local translations [F, J, 3] (file units)."""
    frames = bvh.frame_count
    count = len(bvh.joints)
    rotations = np.broadcast_to(np.eye(3), (frames, count, 3, 3)).copy()
    translations = np.broadcast_to(bvh.offsets, (frames, count, 3)).copy()
    for j, joint in enumerate(bvh.joints):
        angle_columns: list[int] = []
        for k, channel in enumerate(joint.channels):
            column = joint.channel_start + k
            if channel in _POSITION_CHANNELS:
                translations[:, j, _POSITION_CHANNELS[channel]] = bvh.motion[:, column]
            else:
                angle_columns.append(column)
        if angle_columns:
            angles = np.deg2rad(bvh.motion[:, angle_columns])
            rotations[:, j] = euler_to_matrix(angles, _rotation_order(joint))
    return rotations, translations


def write_bvh(
    path: str | Path,
    names: list[str],
    parents: np.ndarray,
    offsets: np.ndarray,
    local_rotations: np.ndarray,
    root_positions: np.ndarray,
    frame_time: float,
    order: str = "ZXY",
    scale: float = 1.0,
) -> None:
    """Write a BVH file: root with 6 channels, other joints with 3 rotation channels.

    ``offsets`` [J, 3] and ``root_positions`` [F, 3] are multiplied by ``scale`` (e.g. 100 to
    write centimetres from metres); ``local_rotations`` is [F, J, 3, 3]; ``order`` is the Euler
    order written in the CHANNELS lines. Parents must precede their children.
    """
    parents = np.asarray(parents)
    children: dict[int, list[int]] = {j: [] for j in range(len(names))}
    for j, parent in enumerate(parents):
        if parent >= 0:
            children[int(parent)].append(j)
    rotation_channels = " ".join(f"{axis}rotation" for axis in order)
    lines = ["HIERARCHY"]

    def emit(j: int, depth: int) -> None:
        pad = "  " * depth
        keyword = "ROOT" if parents[j] < 0 else "JOINT"
        lines.append(f"{pad}{keyword} {names[j]}")
        lines.append(pad + "{")
        x, y, z = (float(v) * scale for v in offsets[j])
        lines.append(f"{pad}  OFFSET {x:.6f} {y:.6f} {z:.6f}")
        if parents[j] < 0:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition {rotation_channels}")
        else:
            lines.append(f"{pad}  CHANNELS 3 {rotation_channels}")
        if children[j]:
            for child in children[j]:
                emit(child, depth + 1)
        else:
            lines.append(f"{pad}  End Site")
            lines.append(pad + "  {")
            lines.append(f"{pad}    OFFSET 0.000000 0.000000 0.000000")
            lines.append(pad + "  }")
        lines.append(pad + "}")

    roots = [j for j in range(len(names)) if parents[j] < 0]
    if len(roots) != 1:
        raise ValueError(f"write_bvh needs exactly one root joint, found {len(roots)}")
    emit(roots[0], 0)
    # Channel order in the MOTION lines follows the depth-first order of the hierarchy.
    depth_first: list[int] = []

    def walk(j: int) -> None:
        depth_first.append(j)
        for child in children[j]:
            walk(child)

    walk(roots[0])
    frames = local_rotations.shape[0]
    euler = np.rad2deg(matrix_to_euler(local_rotations[:, depth_first], order))
    columns = [np.asarray(root_positions, dtype=np.float64) * scale, euler.reshape(frames, -1)]
    table = np.concatenate(columns, axis=1)
    lines.append("MOTION")
    lines.append(f"Frames: {frames}")
    lines.append(f"Frame Time: {frame_time:.7f}")
    lines.extend(" ".join(f"{v:.6f}" for v in row) for row in table)
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
