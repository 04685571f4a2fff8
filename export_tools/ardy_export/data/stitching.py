"""Stitched transitions: long sequences of several clips joined motion-graph style.

The clips are short and hold one action each, so the data has no transitions between
prompts (design.md section 4, "Transitions"). This module builds them:

1. Start with a random clip A. For the next join, compare every candidate exit frame of A
   (leaving at least ``min_segment_frames`` of A, before its last ``overlap`` frames) with
   the candidate entry frames of ``candidates`` random other clips (their first third).
   Frames are compared by a pose descriptor in the root's heading frame: joint positions
   relative to the root's ground point (height kept) and joint velocities (scaled by 0.1 s,
   so both are metres). The join is drawn from the ``top_k`` best candidate clips.
2. B is aligned to A: rotated about +Y so the headings agree at the join and translated so
   the roots' ground points coincide (heights untouched).
3. Cross-fade over ``overlap`` frames (smoothstep weights): local rotations by slerp, root
   position linearly, then FK on the model skeleton; the features of the whole sequence are
   recomputed from the resulting poses (velocities and contacts included), so they are
   consistent across the joins.
4. Each side keeps its own labels: the segment boundary is the middle of the cross-fade.

``stitch_quality`` reports the mean pose distance at the chosen joins against random pairs,
and the joint-velocity jump around the joins against the data's typical frame-to-frame
change.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ardy_export.data.contacts import compute_contacts
from ardy_export.data.features import (
    HEADING_SLICE,
    JOINT_VEL_SLICE,
    features_from_motion,
    heading_from_positions,
    joint_velocities,
    motion_from_features,
)
from ardy_export.data.rotations import (
    matrix_to_quaternion,
    quaternion_slerp,
    quaternion_to_matrix,
    yaw_matrix,
)
from ardy_export.data.skeleton import (
    JOINT_COUNT,
    default_skeleton,
    fk,
    local_from_global_rotations,
)

if TYPE_CHECKING:
    from ardy_export.data.dataset import Clip

VELOCITY_WEIGHT_S = 0.1  # velocities (m/s) enter the descriptor times this (-> metres)
_DESCRIPTOR_STEP = 2  # candidate frames are every other frame


class Segment(NamedTuple):
    start: int  # first frame (inclusive)
    end: int  # last frame (exclusive)
    dataset: str
    content: str
    style: str


class Join(NamedTuple):
    frame: int  # first frame of the cross-fade in the sequence
    clip_a: str
    frame_a: int
    clip_b: str
    frame_b: int
    pose_distance: float  # mean joint distance (m) of the aligned poses at the join


@dataclass
class StitchedSequence:
    features: np.ndarray  # [T, 258] float32
    segments: list[Segment]
    joins: list[Join] = field(default_factory=list)
    fps: float = 20.0
    overlap: int = 0  # cross-fade length (frames) of the joins

    @property
    def frames(self) -> int:
        return int(self.features.shape[0])

    def labels_at(self, frame: int) -> Segment:
        for segment in self.segments:
            if segment.start <= frame < segment.end:
                return segment
        raise IndexError(f"frame {frame} outside the sequence (0..{self.frames - 1})")


def _heading(features: np.ndarray) -> np.ndarray:
    return np.arctan2(features[:, HEADING_SLICE.start + 1], features[:, HEADING_SLICE.start])


def pose_descriptors(features: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heading-frame joint positions (root ground point at the origin) and velocities,
    both [T, 21, 3], from features [T, 258]."""
    _, positions = motion_from_features(features)
    velocities = features[:, JOINT_VEL_SLICE].reshape(-1, JOINT_COUNT, 3).astype(np.float64)
    unyaw = yaw_matrix(-_heading(features.astype(np.float64)))  # [T, 3, 3]
    ground = positions[:, :1] * np.array([1.0, 0.0, 1.0])
    local = np.einsum("tab,tjb->tja", unyaw, positions - ground)
    local_velocities = np.einsum("tab,tjb->tja", unyaw, velocities)
    return local, local_velocities


def pose_distance(
    positions_a: np.ndarray,
    velocities_a: np.ndarray,
    positions_b: np.ndarray,
    velocities_b: np.ndarray,
) -> tuple[float, float]:
    """(mean joint position distance (m), mean joint velocity difference (m/s)) of two
    descriptor frames [21, 3]."""
    return (
        float(np.linalg.norm(positions_a - positions_b, axis=-1).mean()),
        float(np.linalg.norm(velocities_a - velocities_b, axis=-1).mean()),
    )


class _ClipCache:
    """Per-clip descriptors (every other frame, flattened) and poses, computed once."""

    def __init__(self, clips: Sequence[Clip]) -> None:
        self.clips = clips
        self._descriptors: dict[int, np.ndarray] = {}
        self._local: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def local(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        if k not in self._local:
            self._local[k] = pose_descriptors(self.clips[k].features)
        return self._local[k]

    def descriptors(self, k: int) -> np.ndarray:
        """[T, 126] float32: positions and weighted velocities (all frames)."""
        if k not in self._descriptors:
            positions, velocities = self.local(k)
            frames = positions.shape[0]
            self._descriptors[k] = np.concatenate(
                [positions.reshape(frames, -1), VELOCITY_WEIGHT_S * velocities.reshape(frames, -1)],
                axis=1,
            ).astype(np.float32)
        return self._descriptors[k]


def _entry_range(frames: int, overlap: int, min_segment: int) -> np.ndarray:
    last = min(frames - 2 * overlap - min_segment, frames // 3)
    return np.arange(0, max(last, 0) + 1, _DESCRIPTOR_STEP) if last >= 0 else np.arange(0)


def _transform(
    rotations: np.ndarray, positions: np.ndarray, yaw: float, shift: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    m = yaw_matrix(yaw)
    return m @ rotations, positions @ m.T + shift


def build_stitched_sequences(
    clips: Sequence[Clip],
    rng: np.random.Generator,
    count: int,
    max_seconds: float = 20.0,
    *,
    min_seconds: float | None = None,
    fps: float = 20.0,
    overlap_frames: int | None = None,
    candidates: int | None = None,
    min_segment_frames: int | None = None,
    top_k: int | None = None,
) -> list[StitchedSequence]:
    """``count`` stitched sequences, each of a random length in [min_seconds, max_seconds]
    (default min: half of max), from ``clips`` (e.g. the training split, mirrored copies
    included). Settings default to configs/data.yaml (``stitching``)."""
    from ardy_export.data.config import load_data_config

    config = load_data_config()
    overlap = config.stitch_overlap_frames if overlap_frames is None else overlap_frames
    candidates = config.stitch_candidates if candidates is None else candidates
    min_segment = (
        config.stitch_min_segment_frames if min_segment_frames is None else min_segment_frames
    )
    top_k = config.stitch_top_k if top_k is None else top_k
    min_seconds = 0.5 * max_seconds if min_seconds is None else min_seconds
    usable = [k for k, c in enumerate(clips) if c.features.shape[0] >= min_segment + overlap + 2]
    if len(usable) < 2:
        raise ValueError("build_stitched_sequences needs at least two clips long enough to join")
    cache = _ClipCache(clips)
    offsets = default_skeleton().offsets
    sequences = []
    for _ in range(count):
        target = round(rng.uniform(min_seconds, max_seconds) * fps)
        sequences.append(
            _build_one(
                clips,
                cache,
                usable,
                rng,
                target,
                fps,
                overlap,
                candidates,
                min_segment,
                top_k,
                offsets,
            )
        )
    return sequences


def _build_one(
    clips: Sequence[Clip],
    cache: _ClipCache,
    usable: list[int],
    rng: np.random.Generator,
    target: int,
    fps: float,
    overlap: int,
    candidates: int,
    min_segment: int,
    top_k: int,
    offsets: np.ndarray,
) -> StitchedSequence:
    current = int(rng.choice(usable))
    rotations, positions = motion_from_features(clips[current].features)
    entry = 0  # first frame of the current clip still to be used
    out_rot: list[np.ndarray] = []
    out_pos: list[np.ndarray] = []
    length = 0
    segments: list[Segment] = []
    joins: list[Join] = []
    segment_start = 0
    weights = _smoothstep((np.arange(overlap) + 1.0) / (overlap + 1.0))
    while True:
        clip = clips[current]
        frames = clip.features.shape[0]
        exit_lo = entry + min_segment
        exit_hi = frames - overlap
        if length + (frames - entry) >= target or exit_lo > exit_hi:
            take = min(frames - entry, target - length) if length < target else 0
            out_rot.append(rotations[entry : entry + take])
            out_pos.append(positions[entry : entry + take])
            length += take
            segments.append(Segment(segment_start, length, clip.dataset, clip.content, clip.style))
            break
        choice = _choose_join(
            cache, usable, current, exit_lo, exit_hi, rng, candidates, overlap, min_segment, top_k
        )
        if choice is None:
            take = frames - entry
            out_rot.append(rotations[entry:])
            out_pos.append(positions[entry:])
            length += take
            segments.append(Segment(segment_start, length, clip.dataset, clip.content, clip.style))
            break
        exit_frame, nxt, entry_b = choice
        # Align the next clip to the current one at the join.
        rot_b, pos_b = motion_from_features(clips[nxt].features)
        psi_a = float(heading_from_positions(positions[exit_frame]))  # aligned already
        psi_b = float(heading_from_positions(pos_b[entry_b]))
        yaw = psi_a - psi_b
        ground_a = positions[exit_frame, 0] * np.array([1.0, 0.0, 1.0])
        ground_b = (yaw_matrix(yaw) @ pos_b[entry_b, 0]) * np.array([1.0, 0.0, 1.0])
        rot_b, pos_b = _transform(rot_b, pos_b, yaw, ground_a - ground_b)
        local_a, vel_a = cache.local(current)
        local_b, vel_b = cache.local(nxt)
        distance, _ = pose_distance(
            local_a[exit_frame], vel_a[exit_frame], local_b[entry_b], vel_b[entry_b]
        )
        # Frames of the current clip up to the join, then the cross-fade.
        out_rot.append(rotations[entry:exit_frame])
        out_pos.append(positions[entry:exit_frame])
        join_frame = length + (exit_frame - entry)
        blend_rot, blend_pos = _cross_fade(
            rotations[exit_frame : exit_frame + overlap],
            positions[exit_frame : exit_frame + overlap],
            rot_b[entry_b : entry_b + overlap],
            pos_b[entry_b : entry_b + overlap],
            weights,
            offsets,
        )
        out_rot.append(blend_rot)
        out_pos.append(blend_pos)
        length = join_frame + overlap
        boundary = join_frame + overlap // 2
        segments.append(Segment(segment_start, boundary, clip.dataset, clip.content, clip.style))
        joins.append(Join(join_frame, clip.name, exit_frame, clips[nxt].name, entry_b, distance))
        segment_start = boundary
        current, rotations, positions, entry = nxt, rot_b, pos_b, entry_b + overlap
        if length >= target:
            clip = clips[current]
            segments.append(Segment(segment_start, length, clip.dataset, clip.content, clip.style))
            break
    all_rot = np.concatenate(out_rot)[:target]
    all_pos = np.concatenate(out_pos)[:target]
    total = all_pos.shape[0]
    segments = [
        Segment(s.start, min(s.end, total), s.dataset, s.content, s.style)
        for s in segments
        if s.start < total and s.end > s.start
    ]
    velocities = joint_velocities(all_pos, fps)
    contacts = compute_contacts(all_pos, velocities)
    features = features_from_motion(all_rot, all_pos, fps, contacts)
    return StitchedSequence(features, segments, joins, fps, overlap)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    return x * x * (3.0 - 2.0 * x)


def _cross_fade(
    rot_a: np.ndarray,
    pos_a: np.ndarray,
    rot_b: np.ndarray,
    pos_b: np.ndarray,
    weights: np.ndarray,
    offsets: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Blend two aligned pose runs [K, 21, ...]: local rotations by slerp (weight 0 = A),
    root linearly, then FK."""
    local_a = matrix_to_quaternion(local_from_global_rotations(rot_a))
    local_b = matrix_to_quaternion(local_from_global_rotations(rot_b))
    w = weights[:, None]
    local = quaternion_to_matrix(quaternion_slerp(local_a, local_b, w))
    root = (1.0 - w) * pos_a[:, 0] + w * pos_b[:, 0]
    return fk(local, root, offsets)


def _choose_join(
    cache: _ClipCache,
    usable: list[int],
    current: int,
    exit_lo: int,
    exit_hi: int,
    rng: np.random.Generator,
    candidates: int,
    overlap: int,
    min_segment: int,
    top_k: int,
) -> tuple[int, int, int] | None:
    """(exit frame of the current clip, next clip, entry frame of it), or None."""
    exits = np.arange(exit_lo, exit_hi + 1, _DESCRIPTOR_STEP)
    if exits.size == 0:
        return None
    # Compare the whole cross-fade window: frames at these offsets after the exit / entry.
    window = sorted({0, overlap // 2, max(overlap - 1, 0)})
    descriptors = cache.descriptors(current).astype(np.float64)
    source = np.concatenate([descriptors[exits + o] for o in window], axis=1)
    pool = [k for k in usable if k != current]
    picks = rng.choice(len(pool), size=min(candidates, len(pool)), replace=False)
    best: list[tuple[float, int, int, int]] = []
    for p in picks:
        k = pool[int(p)]
        entries = _entry_range(cache.clips[k].features.shape[0], overlap, min_segment)
        if entries.size == 0:
            continue
        other = cache.descriptors(k).astype(np.float64)
        target = np.concatenate([other[entries + o] for o in window], axis=1)
        squared = (
            np.sum(source**2, axis=1)[:, None]
            + np.sum(target**2, axis=1)[None, :]
            - 2.0 * source @ target.T
        )
        i, j = np.unravel_index(int(np.argmin(squared)), squared.shape)
        best.append((float(squared[i, j]), int(exits[i]), k, int(entries[j])))
    if not best:
        return None
    best.sort()
    _, exit_frame, k, entry = best[int(rng.integers(min(top_k, len(best))))]
    return exit_frame, k, entry


def stitch_quality(
    sequences: Sequence[StitchedSequence],
    clips: Sequence[Clip],
    rng: np.random.Generator,
    random_pairs: int = 500,
) -> dict[str, Any]:
    """Quality figures of stitched sequences:

    * ``join_pose_distance_m``: mean joint distance (heading frame) of the aligned poses at
      the chosen joins, ``random_pose_distance_m`` the same for random (clip, frame) pairs,
      and their ratio;
    * ``join_velocity_jump``: mean joint-velocity change per frame (m/s) over the frames of
      each cross-fade (and one frame either side), ``data_velocity_jump`` the mean over all
      frames of the clips, and their ratio (1 = as smooth as the data);
    * ``cut_velocity_jump``: the same at a hard cut (no cross-fade) of the same joins.
    """
    cache = _ClipCache(clips)
    joins = [j for s in sequences for j in s.joins]
    join_distance = float(np.mean([j.pose_distance for j in joins])) if joins else float("nan")
    random_distances = []
    for _ in range(random_pairs):
        a, b = rng.choice(len(clips), size=2, replace=False)
        pa, va = cache.local(int(a))
        pb, vb = cache.local(int(b))
        fa = int(rng.integers(pa.shape[0]))
        fb = int(rng.integers(pb.shape[0]))
        random_distances.append(pose_distance(pa[fa], va[fa], pb[fb], vb[fb])[0])
    random_distance = float(np.mean(random_distances))

    def jump(velocities: np.ndarray) -> np.ndarray:
        return np.linalg.norm(np.diff(velocities, axis=0), axis=-1).mean(axis=-1)

    data_jumps = [
        jump(c.features[:, JOINT_VEL_SLICE].reshape(-1, JOINT_COUNT, 3).astype(np.float64))
        for c in clips
        if c.features.shape[0] > 2
    ]
    data_jump = float(np.concatenate(data_jumps).mean())
    join_jumps = []
    source_jumps = []
    name_to_index = {c.name: k for k, c in enumerate(clips)}
    for sequence in sequences:
        velocities = sequence.features[:, JOINT_VEL_SLICE].reshape(-1, JOINT_COUNT, 3)
        per_frame = jump(velocities.astype(np.float64))
        overlap = sequence.overlap
        for j in sequence.joins:
            lo = max(j.frame - 1, 0)
            hi = min(j.frame + overlap + 1, per_frame.shape[0])
            if hi > lo:
                join_jumps.append(per_frame[lo:hi].mean())
            if j.clip_a in name_to_index:
                source = clips[name_to_index[j.clip_a]].features
                own = jump(source[:, JOINT_VEL_SLICE].reshape(-1, JOINT_COUNT, 3).astype(float))
                a_lo = max(j.frame_a - 1, 0)
                a_hi = min(j.frame_a + overlap + 1, own.shape[0])
                if a_hi > a_lo:
                    source_jumps.append(own[a_lo:a_hi].mean())
    cut_jumps = []
    for sequence in sequences:
        for j in sequence.joins:
            if j.clip_a not in name_to_index or j.clip_b not in name_to_index:
                continue
            pa, va = cache.local(name_to_index[j.clip_a])
            pb, vb = cache.local(name_to_index[j.clip_b])
            # Hard cut: A's exit frame followed by B's next frame (aligned, same heading):
            # the joints move by B's own step plus the pose difference in one frame.
            cut_velocity = (pb[j.frame_b] - pa[j.frame_a]) * sequence.fps + vb[j.frame_b + 1]
            cut_jumps.append(float(np.linalg.norm(cut_velocity - va[j.frame_a], axis=-1).mean()))
    join_jump = float(np.mean(join_jumps)) if join_jumps else float("nan")
    return {
        "joins": len(joins),
        "join_pose_distance_m": round(join_distance, 4),
        "random_pose_distance_m": round(random_distance, 4),
        "pose_distance_ratio": round(join_distance / random_distance, 3),
        "join_velocity_jump": round(join_jump, 4),
        "data_velocity_jump": round(data_jump, 4),
        "velocity_jump_ratio": round(join_jump / data_jump, 3),
        "source_velocity_jump": round(float(np.mean(source_jumps)), 4)
        if source_jumps
        else float("nan"),
        "cut_velocity_jump": round(float(np.mean(cut_jumps)), 4) if cut_jumps else float("nan"),
    }
