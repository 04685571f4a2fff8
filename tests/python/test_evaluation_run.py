"""Evaluation plumbing: the C++ CLI runner, test-case building, constraint errors, report."""

from __future__ import annotations

import copy
import json
import types
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


class _FakeClip:
    """As much of a test clip as constraint cases read."""

    def __init__(
        self, features: np.ndarray, dataset: str = "dataset-2", content: str = "walk"
    ) -> None:
        self.features = features
        self.frames = len(features)
        self.group = (dataset, content, "normal")
        self.name = f"{content}_{len(features)}"


def test_canonical_crop_starts_on_the_origin_facing_plus_z() -> None:
    crop = tasks.canonical_crop(_walk(), 10, 60)
    positions = positions_from_features(crop)
    assert crop.shape == (60, L.FEATURE_SIZE)
    assert np.abs(positions[0, 0, [0, 2]]).max() < 1e-6
    assert abs(float(heading_from_positions(positions[:1])[0])) < 1e-6
    # A walk keeps going forward (+Z) from there.
    assert positions[-1, 0, 2] > 1.0


def test_constraint_cases_take_their_targets_from_the_crop() -> None:
    cases = tasks.constraint_cases([_FakeClip(_walk(8.0))], 120, L.FPS, 2, 80)  # type: ignore[list-item]
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
    short = [_FakeClip(_walk(5.0)), _FakeClip(_walk(3.0)), _FakeClip(_walk(8.0))]
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
    for case in tasks.constraint_cases([_FakeClip(_walk(8.0))], 120, L.FPS, 1, 80):  # type: ignore[list-item]
        assert case.reference is not None
        errors = run.constraint_errors(case, _generated(positions_from_features(case.reference)))
        assert errors["error_m"] == pytest.approx(0.0, abs=1e-9)
        assert errors.get("between_frames_error_m", 0.0) < 0.02
        if case.task == "end_effectors":
            # Identity local rotations are not the reference's: a real angle, not a crash.
            assert errors["rotation_error_deg"] > 1.0


def test_constraint_section_runs_every_case_under_each_seed_set() -> None:
    """seed_sets: 3 runs each case three times with seeds a stride apart and reports the
    mean error beside each set's own (here the fake model is off by 0.1 m per set)."""
    (reference,) = {
        c.reference.tobytes(): c.reference
        for c in tasks.constraint_cases([_FakeClip(_walk(8.0))], 120, L.FPS, 1, 80)  # type: ignore[list-item]
        if c.reference is not None
    }.values()
    seeds: list[int] = []

    def generate(what: str, jobs: list[Job]) -> list[Generated]:
        seeds.extend(job.seed for job in jobs)
        motions = []
        for job in jobs:
            positions = positions_from_features(reference).copy()
            positions[..., 0] += 0.1 * (job.seed // run.SEED_SET_STRIDE)
            motions.append(_generated(positions))
        return motions

    ctx = types.SimpleNamespace(
        config={"constraints": {"clips_per_group": 1, "seed_sets": 3}},
        clips=[_FakeClip(_walk(8.0))],
        frames=120,
        fps=L.FPS,
        min_frames=80,
        feet=list(L.FOOT_JOINTS),
        generate=generate,
    )
    out = run.constraints_section(ctx)  # type: ignore[arg-type]
    assert out["seed_sets"] == 3
    assert len(seeds) == 3 * len(tasks.CONSTRAINT_TASKS) and len(set(seeds)) == len(seeds)
    waypoints = out["tasks"]["waypoints"]
    assert waypoints["count"] == 3
    assert waypoints["error_m_by_seed_set"] == pytest.approx([0.0, 0.1, 0.2], abs=1e-9)
    assert waypoints["error_m"] == pytest.approx(0.1, abs=1e-9)
    # One set (the default): one rollout per case and no per-set figures.
    ctx.config = {"constraints": {"clips_per_group": 1}}
    single = run.constraints_section(ctx)  # type: ignore[arg-type]
    assert single["tasks"]["waypoints"]["count"] == 1
    assert "error_m_by_seed_set" not in single["tasks"]["waypoints"]


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
    assert "## Against the paper" in text and "## Reading these numbers" in text
    assert "## Against the previous package" not in text  # no previous.json
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
    # skate ratio, R-precision, FID and the between-frames waypoint error; the rest is met
    assert text.count("**missed**") == 4
    assert "| text-only foot skate / the dataset's | <= 1.6x | 2.22x | **missed** |" in text
    assert "| prompt response median, all pairs | <= 1.2 s | 1.00 s | met |" in text
    assert "| keyframe joints | <= 0.05 m | 0.050 m | met |" in text
    # The long rollout's jerk beside the test clips' own.
    assert "| mean jerk (m/s^3) | 55.0 (the test clips: 50.0) |" in text
    assert "paraphrases" not in text.split("## Acceptance bars")[1].split("##")[0]
    for png in ("response.png", "stability.png", "contact_sheet.png"):
        assert (tmp_path / png).stat().st_size > 5000
    # The scale line names the denoiser's sizes from model.json, modulation included.
    results["model"]["architecture"] = {
        "denoiser": {"layers": 3, "width": 128, "condition_modulation": True},
        "tokens": {"patch": 4},
        "text_encoder": "all-MiniLM-L6-v2",
    }
    text = report.write_report(results, tmp_path).read_text()
    assert (
        "(3 layers of width 128 with condition modulation, 4-frame patches, text by "
        "all-MiniLM-L6-v2)" in text
    )


def test_response_summary_counts_pairs_that_never_respond() -> None:
    nan = float("nan")
    # 2 of 5 pairs never respond: counted as the 6 s after the change they enter the median.
    summary = run._summary([0.5, 1.0, 1.5, nan, nan], 6.0)
    assert summary["median_responders"] == pytest.approx(1.0)
    assert summary["median"] == pytest.approx(1.5)
    assert not summary["median_at_least"]
    assert (summary["responded"], summary["total"]) == (3, 5)
    assert summary["mean"] == pytest.approx(1.0)
    # Most never respond: the median is a non-responder's, a lower bound.
    late = run._summary([0.5, nan, nan], 6.0)
    assert late["median"] == pytest.approx(6.0) and late["median_at_least"]
    assert late["median_responders"] == pytest.approx(0.5)


def test_balanced_halves_are_disjoint_and_balanced() -> None:
    labels = np.array([0] * 40 + [1] * 2 + [2])  # label 2 has a single crop: left out
    a, b = run.balanced_halves(labels, 5, seed=0)
    assert not set(a.tolist()) & set(b.tolist())
    assert np.bincount(labels[a], minlength=3).tolist() == [5, 5, 0]
    assert np.bincount(labels[b], minlength=3).tolist() == [5, 5, 0]


def _results(skate: float, r_prec: float, response: dict, **text_extra: object) -> dict:
    data = {
        "foot_skate": 0.1,
        "r_precision_top3": 0.9,
        "fid": 0.03,
        "fid_balanced": 0.2,
        "jerk": 60.0,
        "count": 40,
        "contact_agreement": 1.0,
        "seam_jerk": {"across_seams": 30.0, "inside_patches": 30.0, "ratio": 1.0},
    }
    ours = {
        "foot_skate": skate,
        "r_precision_top3": r_prec,
        "fid": 0.61,
        "fid_balanced": 0.45,
        "jerk": 45.0,
        "count": 8,
        "contact_agreement": 0.683,
        "seam_jerk": {"across_seams": 60.0, "inside_patches": 20.0, "ratio": 3.0},
    }
    raw = {
        **ours,
        "foot_skate": 0.5,
        "jerk": 390.0,
        "seam_jerk": {"across_seams": 700.0, "inside_patches": 200.0, "ratio": 3.5},
    }
    return {
        "model": {"path": "pkg", "provenance": {"checkpoint": f"c{skate}.pt", "commit": "abc"}},
        "text": {
            "rows": {
                "dataset (test split)": data,
                "ours, 4 steps": ours,
                "ours, 4 steps, unfiltered": raw,
            },
            "paraphrase_rows": {"ours, 4 steps": {**ours, "r_precision_top3": 0.375}},
            "r_precision_chance": 3 / 31,
            "r_precision_pool": 31,
            "labels": 31,
            **text_extra,
        },
        "response": {
            "pairs": 3,
            "after_seconds": 6.0,
            "response_seconds": response,
            "evaluator_delay_on_real_seconds": run._summary([0.5, 0.75], 6.0),
            "jerk_around_change": 60.0,
            "jerk_overall": 50.0,
            "window_seconds": 2.0,
            "curves": [],
        },
    }


def test_report_figures_come_from_the_results(tmp_path: Path) -> None:
    nan = float("nan")
    now = _results(0.22, 0.512, run._summary([1.0, nan, nan], 6.0))
    text = report.write_report(now, tmp_path).read_text()
    # The prose quotes the results, not hand-written figures.
    assert "**Foot skate is 2.20x the test clips'**" in text
    assert "R-precision 0.512 against 0.900" in text
    assert "0.375 with held-out paraphrases" in text
    assert "3.5x that inside a patch" in text and "68 % of the time" in text
    # Response: both medians, the all-pairs one a lower bound here.
    assert "| ours | >= 6.00 | 1.00 | 1.00 | 1/3 |" in text
    assert "counts a pair that never responds as 6 s" in text
    assert (
        "**Prompt response.** Median >= 6.00 s over all 3 pairs (bar: 1.2 s), 1.00 s over "
        "the 1 that respond; 2 never do within 6 s" in text
    )
    assert "faster than the data does" not in text  # the real clips' 0.62 s is under the bar
    slow_real = copy.deepcopy(now)
    slow_real["response"]["evaluator_delay_on_real_seconds"] = run._summary([1.25, 1.5], 6.0)
    slow_text = report.write_report(slow_real, tmp_path).read_text()
    assert "takes 1.38 s" in slow_text and "faster than the data does" in slow_text
    # Paper comparison: our ratio to our data next to the paper's (1.04x skate, 0.86x R-prec).
    assert "| foot skate (m/s) | 0.220 | 0.100 | 2.20x | 0.264 | 0.255 | 1.04x |" in text
    assert "| R-precision top-3 | 0.512 | 0.900 | 0.57x | 0.655 | 0.766 | 0.86x |" in text
    # In-bank vs paraphrase, and the new columns.
    assert "| ours, 4 steps | 0.512 | 0.375 | 0.73x |" in text
    assert "| ours, 4 steps, unfiltered | 0.683 | 700.0 | 200.0 | 3.50 |" in text
    # A previous package's results.json copied to previous.json is shown next to this one.
    old_resp = run._summary([1.5, 2.0, nan], 6.0)
    old = _results(0.34, 0.496, old_resp)
    (tmp_path / "previous.json").write_text(json.dumps(old))
    text = report.write_report(now, tmp_path).read_text()
    assert "## Against the previous package" in text
    assert "`c0.34.pt`" in text
    assert "| R-precision top-3, in-bank | 0.512 | 0.496 |" in text
    assert "| response median, all pairs (s) | >= 6.00 | 2.00 |" in text
    # Candidates tried and not shipped: one column each, then what they changed.
    assert "## Packages tried and not shipped" not in text
    (tmp_path / "tried").mkdir()
    (tmp_path / "tried" / "b_more.json").write_text(json.dumps(_results(0.30, 0.45, old_resp)))
    (tmp_path / "tried" / "a_less.json").write_text(json.dumps(_results(0.25, 0.40, old_resp)))
    (tmp_path / "tried" / "README.md").write_text("`a_less`: fewer steps.\n")
    text = report.write_report(now, tmp_path).read_text()
    assert "| measure | shipped | `a_less` | `b_more` |" in text
    assert "| R-precision top-3, in-bank | 0.512 | 0.400 | 0.450 |" in text
    assert "`a_less`: fewer steps." in text
    # Numbered candidates stand in the order they were made, not the names' letters.
    for name in ("stage10", "stage4_decoder", "stage9"):
        (tmp_path / "tried" / f"{name}.json").write_text(json.dumps(_results(0.30, 0.45, old_resp)))
    text = report.write_report(now, tmp_path).read_text()
    assert "| shipped | `a_less` | `b_more` | `stage4_decoder` | `stage9` | `stage10` |" in text


def test_report_gives_r_precision_by_content(tmp_path: Path) -> None:
    now = _results(0.22, 0.5, run._summary([1.0], 6.0), train_clips_by_content={"d1/bow": 13})
    shipped = now["text"]["rows"]["ours, 4 steps"]
    shipped["r_precision_top3_by_label"] = {"d1/bow/happy": 0.25, "d1/bow/normal": 0.5}
    shipped["r_precision_top3_by_label"]["d2/walk/sad"] = 1.0
    shipped.update(count=12, labels=3)
    para = now["text"]["paraphrase_rows"]["ours, 4 steps"]
    para["r_precision_top3_by_label"] = {"d1/bow/happy": 0.0, "d1/bow/normal": 0.5}
    text = report.write_report(now, tmp_path).read_text()
    assert "| `d1/bow` | happy, normal | 13 | 0.38 | 0.25 |" in text
    assert "| `d2/walk` | sad | n/a | 1.00 | n/a |" in text
    assert (
        "By dataset, R-precision is 0.38 over the 2 d1 labels (13 training clips per content), "
        "1.00 over the 1 d2 labels (R-precision by content)" in text
    )
    # 4 rollouts per label: (0.25 * 0.75 + 0.5 * 0.5 + 0) / 3, square root, over 3 labels.
    assert "With 4 rollouts per label the in-bank figure has a standard error of 0.127:" in text
    # Results from before the per-label figures have no such table.
    assert (
        "R-precision by content"
        not in report.write_report(
            _results(0.2, 0.5, run._summary([1.0], 6.0)), tmp_path
        ).read_text()
    )


def test_constraint_errors_by_label_tell_walks_from_standing() -> None:
    walk = _walk(8.0)
    still = walk.copy()
    still[:, [0, 2]] = walk[:1, [0, 2]]  # the same body, its root held in place

    cases = [
        c
        for c in tasks.constraint_cases(
            [_FakeClip(walk, "dataset-1", "walk"), _FakeClip(still, "dataset-1", "bow")],  # type: ignore[list-item]
            120,
            L.FPS,
            1,
            80,
        )
        if c.task == "waypoints"
    ]
    errors = [{"error_m": 0.8 if c.group[1] == "walk" else 0.2} for c in cases]
    by_label = run._errors_by_label(cases, errors)
    assert set(by_label) == {"dataset-1/walk/normal", "dataset-1/bow/normal"}
    walked = by_label["dataset-1/walk/normal"]
    assert walked["error_m"] == 0.8 and walked["count"] == 1
    assert 3.0 < walked["travel_m"] < 12.0  # a synthetic walk of 4 s, at 1-2 m/s
    assert by_label["dataset-1/bow/normal"]["travel_m"] == pytest.approx(0.0, abs=1e-6)
    row = {"by_label": {**by_label, "dataset-2/wave/normal": {**walked, "travel_m": 0.1}}}
    assert report._travelling_share(row) == (
        " Of the model's own waypoint error, 44 % is the 1 rollouts whose real root travels over "
        "1 m (runs and walks: 0.800 m off on average, the other 2 0.500 m); their in-between "
        "waypoints fall just past a window's end, where the model runs past or lags them "
        "(packages tried)."
    )
    assert report._travelling_share({}) == ""


def test_r_precision_standard_error_adds_up_the_labels() -> None:
    # Two labels of 5 rollouts: rates 0.4 and 1.0; only the uncertain one contributes.
    row = {"count": 10, "labels": 2, "r_precision_top3_by_label": {"a": 0.4, "b": 1.0}}
    assert report.r_precision_standard_error(row) == pytest.approx(np.sqrt(0.4 * 0.6 / 4) / 2)
    # Every label certain: no sampling error.
    row["r_precision_top3_by_label"] = {"a": 0.0, "b": 1.0}
    assert report.r_precision_standard_error(row) == 0.0
    # Without per-label rates, or with one rollout per label, there is no figure.
    assert report.r_precision_standard_error({"count": 10, "labels": 2}) is None
    row = {"count": 2, "labels": 2, "r_precision_top3_by_label": {"a": 0.0, "b": 1.0}}
    assert report.r_precision_standard_error(row) is None
