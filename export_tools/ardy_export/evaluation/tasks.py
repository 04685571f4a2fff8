"""Evaluation cases built from the held-out test clips (paper Tables 2 and 3).

Every case is a CLI job (a JSON timeline) plus what it is measured against. Real crops are
put where generated motion starts: root on the ground origin, facing +Z (heading 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ardy_export.data.augment import rotate_yaw
from ardy_export.data.dataset import Clip
from ardy_export.data.features import heading_from_positions, positions_from_features, recenter
from ardy_export.data.rotations import matrix_from_rot6d
from ardy_export.evaluation.generate import Job
from ardy_export.models import layout as L
from ardy_export.text import sentences as text_sentences

Group = tuple[str, str, str]
CONSTRAINT_TASKS = ("root", "waypoints", "keyframes", "end_effectors")
END_EFFECTOR_NAMES = ("Hand_L", "Hand_R", "Foot_L", "Foot_R", "Head")


@dataclass
class Case:
    task: str  # "text" or one of CONSTRAINT_TASKS
    group: Group
    prompt: str
    sentence: int  # index of the prompt among the label's bank sentences
    job: Job
    reference: np.ndarray | None = None  # the canonical real crop's features [T, M]
    frames: list[int] = field(default_factory=list)  # constrained frames
    joints: list[int] = field(default_factory=list)  # constrained joints (end effectors)


def canonical_crop(features: np.ndarray, start: int, frames: int) -> np.ndarray:
    """``frames`` frames from ``start``, moved so that the first frame's root is on the origin
    and faces +Z."""
    crop = np.asarray(features[start : start + frames], np.float64)
    heading = float(heading_from_positions(positions_from_features(crop[:1]))[0])
    crop, _ = recenter(crop, 0)
    return np.asarray(rotate_yaw(crop, -heading), np.float64)


def test_crops(
    clips: list[Clip], frames: int, stride: int, min_frames: int
) -> list[tuple[Group, np.ndarray]]:
    """Every ``frames``-long crop (every ``stride`` frames) of the clips, canonical; a clip
    shorter than ``frames`` but at least ``min_frames`` long is one crop (most dataset-2
    clips last 4.4 s)."""
    out = []
    for clip in clips:
        if min_frames <= clip.frames < frames:
            out.append((clip.group, canonical_crop(clip.features, 0, clip.frames)))
        for start in range(0, clip.frames - frames + 1, stride):
            out.append((clip.group, canonical_crop(clip.features, start, frames)))
    return out


def _prompt(group: Group, sentence: int) -> str:
    dataset, content, style = group
    return text_sentences.sentences_for(dataset, content, style, count=sentence + 1)[sentence]


def text_cases(groups: list[Group], samples: int, seconds: float, sentences: int) -> list[Case]:
    """Text only: ``samples`` rollouts per label, each with another paraphrase and seed."""
    cases = []
    for g, group in enumerate(groups):
        for s in range(samples):
            k = s % sentences
            prompt = _prompt(group, k)
            job = Job({"prompts": [{"time": 0.0, "text": prompt}]}, seconds, seed=1000 * g + s)
            cases.append(Case("text", group, prompt, k, job))
    return cases


def load_paraphrases(path: str | Path) -> dict[Group, list[str]]:
    """The held-out paraphrases (configs/paraphrases.yaml): ``dataset/content/style`` ->
    hand-written sentences the sentence grammar does not produce."""
    import yaml

    raw = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    out: dict[Group, list[str]] = {}
    for key, sentences in raw.items():
        parts = tuple(str(key).split("/"))
        if len(parts) != 3 or not sentences or not all(isinstance(s, str) for s in sentences):
            raise ValueError(f"{path}: {key!r} must be dataset/content/style: [sentences]")
        out[(parts[0], parts[1], parts[2])] = [s.strip() for s in sentences]
    return out


def paraphrase_cases(
    groups: list[Group],
    paraphrases: dict[Group, list[str]],
    samples: int,
    seconds: float,
    sentences: int,
) -> list[Case]:
    """Text only with held-out paraphrases: ``samples`` rollouts per label, rollout s prompted
    with paraphrase ``s % len`` and seeded as ``text_cases`` seeds it. ``Case.sentence`` is
    the bank sentence ``s % sentences`` (the one the in-bank rollout s is scored against):
    R-precision compares the motion with the label bank's embedding of the label, never
    with an embedding of the paraphrase."""
    missing = [g for g in groups if not paraphrases.get(g)]
    if missing:
        raise ValueError(f"no held-out paraphrases for the test labels {missing}")
    cases = []
    for g, group in enumerate(groups):
        own = paraphrases[group]
        for s in range(samples):
            prompt = own[s % len(own)]
            job = Job({"prompts": [{"time": 0.0, "text": prompt}]}, seconds, seed=1000 * g + s)
            cases.append(Case("paraphrase", group, prompt, s % sentences, job))
    return cases


def _constraints(
    task: str, crop: np.ndarray, fps: float, joints: list[int]
) -> list[dict[str, Any]]:
    """The timeline constraints of one task, taken from the real crop."""
    frames = len(crop)
    root_xz = crop[:, [0, 2]]
    if task == "root":
        return [{"type": "path", "start_frame": 0, "positions": root_xz.tolist()}]
    marks = constrained_frames(task, frames, fps)
    if task == "waypoints":
        return [
            {"type": "waypoint", "frame": f, "x": float(root_xz[f, 0]), "z": float(root_xz[f, 1])}
            for f in marks
        ]
    if task == "keyframes":
        return [{"type": "keyframe", "frame": f, "features": crop[f].tolist()} for f in marks]
    targets = []
    rotations = matrix_from_rot6d(crop[:, L.ROT6D_SLICE].reshape(frames, -1, 6))
    for f in marks:
        for j in joints:
            targets.append(
                {
                    "type": "joint",
                    "frame": f,
                    "joint": L.JOINT_NAMES[j],
                    "position": crop[f, L.joint_pos_slice(j)].tolist(),
                    "rotation": rotations[f, j].tolist(),
                }
            )
    return targets


def constrained_frames(task: str, frames: int, fps: float) -> list[int]:
    """The frames a task constrains: waypoints every 2 s (and the last frame), two
    keyframes, two end-effector times."""
    if task == "root":
        return list(range(frames))
    if task == "waypoints":
        marks = list(range(round(2 * fps), frames, round(2 * fps)))
        return marks if marks and marks[-1] == frames - 1 else [*marks, frames - 1]
    if task == "keyframes":
        return [frames // 2, frames - frames // 8]
    return [frames * 3 // 8, frames * 3 // 4]


def constraint_cases(
    clips: list[Clip], frames: int, fps: float, clips_per_group: int, min_frames: int
) -> list[Case]:
    """Each constraint task on the middle ``frames`` frames (the whole clip when shorter,
    down to ``min_frames``) of up to ``clips_per_group`` clips per test group, longest
    clips first, with the label's canonical prompt (text and constraints together, as in
    the paper's Table 3)."""
    by_group: dict[Group, list[Clip]] = {}
    for clip in sorted(clips, key=lambda c: (-c.frames, c.name)):
        if clip.frames >= min_frames:
            by_group.setdefault(clip.group, []).append(clip)
    effectors = [L.JOINT_NAMES.index(n) for n in END_EFFECTOR_NAMES]
    cases = []
    for g, (group, members) in enumerate(sorted(by_group.items())):
        for c, clip in enumerate(members[:clips_per_group]):
            length = min(frames, clip.frames)
            crop = canonical_crop(clip.features, (clip.frames - length) // 2, length)
            prompt = _prompt(group, 0)
            for t, task in enumerate(CONSTRAINT_TASKS):
                rng = np.random.default_rng(7919 * g + 31 * c + t)
                joints = sorted(rng.choice(effectors, size=2, replace=False).tolist())
                timeline = {
                    "prompts": [{"time": 0.0, "text": prompt}],
                    "constraints": _constraints(task, crop, fps, joints),
                }
                job = Job(timeline, length / fps, seed=100 * g + 10 * c + t)
                cases.append(
                    Case(
                        task,
                        group,
                        prompt,
                        0,
                        job,
                        reference=crop,
                        frames=constrained_frames(task, length, fps),
                        joints=joints if task == "end_effectors" else [],
                    )
                )
    return cases
