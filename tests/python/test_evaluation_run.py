"""Evaluation plumbing: the C++ CLI runner, test-case building, constraint errors, report."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ardy_export.data.features import heading_from_positions, positions_from_features
from ardy_export.evaluation import report, run, tasks
from ardy_export.evaluation.generate import CliRunner, Generated, Job, find_cli
from ardy_export.models import layout as L
from ardy_export.training.synthetic import rotate_features_yaw, synthetic_clip


def _cli(build: Path) -> Path:
    return find_cli(str(build / "src" / "ardy-generate"))


def _walk(seconds: float = 6.0) -> np.ndarray:
    features = synthetic_clip("walk", "normal", seconds, np.random.default_rng(0))
    moved = rotate_features_yaw(features, 1.1)
    moved[:, [0, 2]] += [3.0, -2.0]
    return moved


def test_canonical_crop_starts_on_the_origin_facing_plus_z() -> None:
    crop = tasks.canonical_crop(_walk(), 10, 60)
    positions = positions_from_features(crop)
    assert crop.shape == (60, L.FEATURE_SIZE)
    assert np.abs(positions[0, 0, [0, 2]]).max() < 1e-6
    assert abs(float(heading_from_positions(positions[:1])[0])) < 1e-6
    # A walk keeps going forward (+Z) from there.
    assert positions[-1, 0, 2] > 1.0


def test_constraint_cases_take_their_targets_from_the_crop() -> None:
    class FakeClip:
        def __init__(self, features: np.ndarray) -> None:
            self.features = features
            self.frames = len(features)
            self.group = ("dataset-2", "walk", "normal")
            self.name = f"walk_{len(features)}"

    cases = tasks.constraint_cases([FakeClip(_walk(8.0))], 120, L.FPS, 2, 80)  # type: ignore[list-item]
    assert [c.task for c in cases] == list(tasks.CONSTRAINT_TASKS)
    by_task = {c.task: c for c in cases}
    waypoints = by_task["waypoints"].job.timeline["constraints"]
    assert [w["frame"] for w in waypoints] == [40, 80, 119]
    root = positions_from_features(by_task["waypoints"].reference)[:, 0]
    assert waypoints[1]["x"] == pytest.approx(root[80, 0])
    assert len(by_task["root"].job.timeline["constraints"][0]["positions"]) == 120
    effectors = by_task["end_effectors"].job.timeline["constraints"]
    assert len(effectors) == 4 and all(e["joint"] in tasks.END_EFFECTOR_NAMES for e in effectors)
    assert by_task["keyframes"].job.timeline["prompts"][0]["text"] == "a person walks forward"
    # A clip shorter than the rollout is used whole, down to the evaluator's 4 s; shorter
    # clips are left out. The longest clips come first.
    short = [FakeClip(_walk(5.0)), FakeClip(_walk(3.0)), FakeClip(_walk(8.0))]
    cases = tasks.constraint_cases(short, 120, L.FPS, 2, 80)  # type: ignore[arg-type]
    assert [c.job.seconds for c in cases] == [6.0] * 4 + [5.0] * 4
    assert tasks.constrained_frames("waypoints", 100, L.FPS) == [40, 80, 99]
    crops = tasks.test_crops(short, 120, 60, 80)  # type: ignore[arg-type]
    assert sorted(len(c) for _, c in crops) == [100, 120]


def test_midpoint_error_tells_passing_through_from_jumping() -> None:
    line = np.stack([np.linspace(0, 2, 41), np.zeros(41)], axis=1)
    assert run._midpoint_error(line, line, [20]) == pytest.approx(0.0, abs=1e-12)
    jumped = line.copy()
    target = line.copy()
    target[20] = [1.0, 0.5]
    jumped[20] = target[20]  # only the constrained frame moved
    assert run._midpoint_error(jumped, target, [20]) == pytest.approx(0.5)


@pytest.mark.requires_build
def test_cli_runner_runs_the_tiny_package(repo_root: Path, build: Path) -> None:
    runner = CliRunner(_cli(build), repo_root / "tests/data/tiny_package", workers=2)
    waypoint = {"type": "waypoint", "frame": 30, "x": 1.5, "z": 2.0}
    jobs = [
        Job({"prompts": [{"time": 0, "text": "a person walks"}], "constraints": [waypoint]}, 3.0),
        Job({"prompts": [{"time": 0, "text": "a person waves"}]}, 2.0, seed=3, steps=2),
    ]
    first, second = runner.run(jobs)
    assert first.positions.shape == (60, len(first.joints), 3)
    assert second.positions.shape[0] == 40
    assert first.positions[30, 0, [0, 2]] == pytest.approx([1.5, 2.0], abs=1e-3)
    rotations = first.global_rotations()
    identity = np.swapaxes(rotations, -1, -2) @ rotations
    assert np.abs(identity - np.eye(3)).max() < 1e-3
    # Global rotations agree with the positions: each child's offset from its parent is the
    # parent's rotation applied to a fixed rest offset.
    parent = first.parents[L.JOINT_NAMES.index("LowerArm_L")]
    child = L.JOINT_NAMES.index("LowerArm_L")
    offsets = np.einsum(
        "tji,tj->ti", rotations[:, parent], first.positions[:, child] - first.positions[:, parent]
    )
    assert np.abs(offsets - offsets[0]).max() < 2e-3


@pytest.mark.requires_build
def test_cli_runner_reports_a_failing_timeline(repo_root: Path, build: Path) -> None:
    runner = CliRunner(_cli(build), repo_root / "tests/data/tiny_package")
    bad = Job(
        {"constraints": [{"type": "joint", "time": 1, "joint": "Tail", "position": [0, 1, 0]}]}, 2.0
    )
    with pytest.raises(RuntimeError, match="unknown joint 'Tail'"):
        runner.run([bad])


def _generated(positions: np.ndarray) -> Generated:
    count = positions.shape[1]
    return Generated(
        fps=L.FPS,
        joints=list(L.JOINT_NAMES),
        parents=list(L.PARENTS),
        positions=positions,
        local_rotations=np.broadcast_to(np.eye(3), (len(positions), count, 3, 3)).copy(),
        contacts=np.zeros((len(positions), 4)),
        wall_seconds=0.0,
    )


def test_constraint_errors_are_zero_for_the_reference_itself() -> None:
    walk = _walk(8.0)

    class FakeClip:
        features = walk
        frames = len(walk)
        group = ("dataset-2", "walk", "normal")
        name = "walk"

    for case in tasks.constraint_cases([FakeClip()], 120, L.FPS, 1, 80):  # type: ignore[list-item]
        assert case.reference is not None
        errors = run.constraint_errors(case, _generated(positions_from_features(case.reference)))
        assert errors["error_m"] == pytest.approx(0.0, abs=1e-9)
        assert errors.get("between_frames_error_m", 0.0) < 0.02
        if case.task == "end_effectors":
            # Identity local rotations are not the reference's: a real angle, not a crash.
            assert errors["rotation_error_deg"] > 1.0


def test_report_lists_every_section_and_marks_missed_bars(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    row = {"foot_skate": 0.09, "r_precision_top3": 0.4, "fid": 1.2, "jerk": 50.0, "count": 8}
    walk = positions_from_features(_walk(2.0))
    results = {
        "model": {"path": "pkg", "provenance": {"checkpoint": "c.pt", "commit": "abc"}},
        "text": {
            "rows": {"dataset (test split)": row, "ours, 4 steps": {**row, "foot_skate": 0.2}},
            "r_precision_chance": 3 / 32,
            "labels": 35,
        },
        "constraints": {
            "tasks": {
                "waypoints": {
                    "error_m": 0.0,
                    "between_frames_error_m": 0.3,
                    "foot_skate": 0.1,
                    "count": 4,
                },
                "keyframes": {"error_m": 0.05, "pose_error_m": 0.04, "foot_skate": 0.1, "count": 4},
            },
            "dataset_foot_skate": 0.08,
        },
        "response": {
            "pairs": 2,
            "response_seconds": {"median": 1.0, "mean": 1.2, "responded": 2, "total": 2},
            "evaluator_delay_on_real_seconds": {
                "median": 0.5,
                "mean": 0.5,
                "responded": 1,
                "total": 2,
            },
            "jerk_around_change": 60.0,
            "jerk_overall": 50.0,
            "window_seconds": 2.0,
            "curves": [{"pair": [], "t": [2.0, 3.0, 5.0], "margin": [-0.2, -0.1, 0.3]}],
        },
        "stability": {
            "seconds": 10.0,
            "prompts": 2,
            "finite": True,
            "lowest_joint_m": -0.01,
            "frames_below_floor_5cm": 0,
            "hips_height_m": {"min": 0.8, "max": 0.95, "per_minute_mean": [0.9]},
            "root_speed_m_s": {"mean": 1.0, "max": 2.0},
            "yaw_rate_deg_s": {"mean": 10.0, "p99": 90.0},
            "distance_from_start_m": 4.0,
            "jerk": 55.0,
            "trace": {"t": [0.0, 1.0], "hips_height": [0.9, 0.9], "x": [0, 1], "z": [0, 1]},
        },
        "contrasts": {
            "samples": 1,
            "pairs": [
                {
                    "a": ["d", "walk", "normal"],
                    "b": ["d", "run", "normal"],
                    "d/walk/normal": dict.fromkeys(
                        ("speed_m_s", "turn_deg", "hand_l_top_m", "hand_r_top_m"), 1.0
                    ),
                    "d/run/normal": dict.fromkeys(
                        ("speed_m_s", "turn_deg", "hand_l_top_m", "hand_r_top_m"), 2.0
                    ),
                    "evaluator_tells_apart": 1.0,
                }
            ],
            "sheet": {
                "d/walk/normal": report.sheet_entry(walk, L.FPS),
                "d/run/normal": report.sheet_entry(walk + rng.normal(0, 0.01, walk.shape), L.FPS),
            },
            "prompts": {"d/walk/normal": "a person walks", "d/run/normal": "a person runs"},
        },
    }
    path = report.write_report(results, tmp_path)
    text = path.read_text()
    for heading in (
        "Text to motion",
        "Constraints",
        "Prompt response",
        "Long rollout",
        "Prompts that must differ",
        "Acceptance bars",
    ):
        assert f"## {heading}" in text
    assert "2.22x" in text  # skate ratio 0.2 / 0.09
    assert text.count("**missed**") == 2  # skate ratio and the between-frames waypoint error
    for png in ("response.png", "stability.png", "contact_sheet.png"):
        assert (tmp_path / png).stat().st_size > 5000
