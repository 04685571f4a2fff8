"""The evaluation report: ``results.json`` (from ``run.py``) -> ``README.md`` + PNG plots."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ardy_export.models import layout as L

# Suffix of the constraint rows run without the runtime's root interpolation (run.py).
MODEL_ONLY = ", model only"
# The acceptance bars of the "Train, evaluate and ship" issue.
SKATE_RATIO_BAR = 1.5
WAYPOINT_BAR_M = 0.15
KEYFRAME_BAR_M = 0.10


def _f(value: float | None, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:.{digits}f}"


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(r) + " |" for r in rows]


def _text_lines(text: dict[str, Any]) -> list[str]:
    chance = text["r_precision_chance"]
    rows = [
        [
            name,
            _f(r["foot_skate"]),
            _f(r["r_precision_top3"]),
            _f(r["fid"]),
            _f(r["jerk"], 1),
            str(r["count"]),
        ]
        for name, r in text["rows"].items()
    ]
    return [
        "## Text to motion (paper Table 2)",
        "",
        f"Held-out test split: {text['labels']} labels. Generated: 6 s rollouts, the same "
        "number per label, each with another paraphrase of the label and another seed. "
        "Dataset: 6 s crops of the test clips (a clip of 2 to 6 s is one crop). "
        f"R-precision: top 3 among 32 texts of distinct labels (chance {chance:.3f}). FID "
        "between evaluator embeddings of the motion and of the test crops (the dataset row: "
        "two random halves of the crops). Skate: horizontal foot speed while a foot joint is "
        "below its height threshold; skate and jerk are averaged per label, then over the "
        "labels (the test clips are spread very unevenly over the labels). *Unfiltered*: "
        "the model's raw output, without the runtime's output filter (`--smoothing 0`).",
        "",
        *_table(
            ["", "foot skate (m/s)", "R-precision top-3", "FID", "jerk (m/s^3)", "motions"], rows
        ),
        "",
    ]


def _constraint_lines(con: dict[str, Any]) -> list[str]:
    names = {
        "root": "root trajectory (dense path)",
        "waypoints": "sparse waypoints (every 2 s)",
        "keyframes": "full-body keyframes (2)",
        "end_effectors": "end effectors (2 joints x 2 times)",
    }
    rows = []
    for task, r in con["tasks"].items():
        base, _, variant = task.partition(", ")
        rows.append(
            [
                names.get(base, base) + (f", {variant}" if variant else ""),
                _f(r.get("error_m")),
                _f(r.get("between_frames_error_m")),
                _f(r.get("pose_error_m")),
                _f(r.get("rotation_error_deg"), 1),
                _f(r["foot_skate"]),
                str(r["count"]),
            ]
        )
    return [
        "## Constraints (paper Table 3)",
        "",
        "The middle 6 s of the longest test clips of each label (the whole clip when it "
        "lasts 2 to 6 s), moved to start on the origin facing +Z; the constraints are taken "
        "from the crop and the label's canonical prompt is given too. Error: at the "
        "constrained frames (root: ground position; keyframes: all joints in world space; "
        "end effectors: position relative to the root's ground point, and world rotation). "
        "The runtime overwrites constrained root values in the model's output and then "
        "applies its output filter, so a root the motion does not reach by itself is pulled "
        "only part of the way; *between frames* is the distance from the target to the "
        "midpoint of the frames just before and after it (large when the motion jumps "
        "towards the target for one frame instead of passing through it). *Pose*: keyframe "
        "joints relative to the root's ground point. Shipped packages turn sparse root "
        "targets (waypoints, keyframe roots) into a straight path from the character's "
        "position (`interpolate_root`); *model only* rows switch that off "
        "(`--interpolate-root off`) and show what the model does with isolated targets.",
        "",
        *_table(
            [
                "task",
                "error (m)",
                "between frames (m)",
                "pose (m)",
                "rotation (deg)",
                "foot skate (m/s)",
                "rollouts",
            ],
            rows,
        ),
        "",
        f"Dataset foot skate on the same crops: {_f(con['dataset_foot_skate'])} m/s.",
        "",
    ]


def _response_lines(resp: dict[str, Any], out: Path) -> list[str]:
    _plot_response(resp, out / "response.png")
    ours, real = resp["response_seconds"], resp["evaluator_delay_on_real_seconds"]
    return [
        "## Prompt response and transitions",
        "",
        f"{resp['pairs']} pairs of test labels with different contents: prompt A for 4 s, "
        f"then prompt B. The evaluator reads trailing {resp['window_seconds']:g} s windows "
        "every 0.25 s; the response time is the first time B is preferred to A and stays "
        "so for 0.5 s. The same measurement on real clips of A followed by real clips of B "
        "is the evaluator's own delay.",
        "",
        *_table(
            ["", "median (s)", "mean (s)", "responded"],
            [
                [
                    "ours",
                    _f(ours["median"], 2),
                    _f(ours["mean"], 2),
                    f"{ours['responded']}/{ours['total']}",
                ],
                [
                    "real A -> B (evaluator delay)",
                    _f(real["median"], 2),
                    _f(real["mean"], 2),
                    f"{real['responded']}/{real['total']}",
                ],
            ],
        ),
        "",
        f"Jerk from 0.5 s before to 1 s after the change: {_f(resp['jerk_around_change'], 1)} "
        f"m/s^3, against {_f(resp['jerk_overall'], 1)} m/s^3 over the whole rollouts.",
        "",
        "![evaluator preference for B over A around the prompt change](response.png)",
        "",
    ]


def _stability_lines(st: dict[str, Any], out: Path) -> list[str]:
    _plot_stability(st, out / "stability.png")
    return [
        "## Long rollout",
        "",
        f"{st['seconds']:g} s in one CLI run, the prompt changing every 10 s through "
        f"{st['prompts']} prompts.",
        "",
        *_table(
            ["measure", "value"],
            [
                ["all values finite", str(st["finite"])],
                ["lowest joint (m)", _f(st["lowest_joint_m"])],
                [
                    "frames with a joint more than 5 cm below the floor",
                    str(st["frames_below_floor_5cm"]),
                ],
                [
                    "hips height min / max (m)",
                    f"{_f(st['hips_height_m']['min'])} / {_f(st['hips_height_m']['max'])}",
                ],
                [
                    "hips height, mean per minute (m)",
                    ", ".join(_f(v) for v in st["hips_height_m"]["per_minute_mean"]),
                ],
                [
                    "root speed mean / max (m/s)",
                    f"{_f(st['root_speed_m_s']['mean'], 2)} / {_f(st['root_speed_m_s']['max'], 2)}",
                ],
                [
                    "yaw rate mean / p99 (deg/s)",
                    f"{_f(st['yaw_rate_deg_s']['mean'], 1)} / {_f(st['yaw_rate_deg_s']['p99'], 1)}",
                ],
                ["distance from the start at the end (m)", _f(st["distance_from_start_m"], 1)],
                ["mean jerk (m/s^3)", _f(st["jerk"], 1)],
            ],
        ),
        "",
        "![hips height and ground path of the long rollout](stability.png)",
        "",
    ]


def _contrast_lines(con: dict[str, Any], out: Path) -> list[str]:
    _plot_sheet(con, out / "contact_sheet.png")
    rows = []
    for pair in con["pairs"]:
        a, b = "/".join(pair["a"]), "/".join(pair["b"])
        ma, mb = pair[a], pair[b]
        rows.append(
            [
                f"{a.split('/', 1)[1]} vs {b.split('/', 1)[1]}",
                _f(pair["evaluator_tells_apart"], 2),
                f"{_f(ma['speed_m_s'], 2)} / {_f(mb['speed_m_s'], 2)}",
                f"{_f(ma['turn_deg'], 0)} / {_f(mb['turn_deg'], 0)}",
                f"{_f(ma['hand_l_top_m'], 2)}, {_f(ma['hand_r_top_m'], 2)} / "
                f"{_f(mb['hand_l_top_m'], 2)}, {_f(mb['hand_r_top_m'], 2)}",
            ]
        )
    return [
        "## Prompts that must differ",
        "",
        f"{con['samples']} rollouts of 6 s per prompt (canonical prompts of the labels). "
        "*Told apart*: the fraction of rollouts the evaluator matches to their own prompt "
        "rather than the other one (0.5 = no difference). Measures are means over the "
        "rollouts, A / B; turn is positive to the left (counter-clockwise seen from above).",
        "",
        *_table(
            ["A vs B", "told apart", "speed (m/s)", "turn (deg)", "top of hands L, R (m)"],
            rows,
        ),
        "",
        "![one rollout per prompt: poses every second, seen from the front, and the ground "
        "path](contact_sheet.png)",
        "",
    ]


def _bars_lines(results: dict[str, Any]) -> list[str]:
    text = results.get("text", {}).get("rows", {})
    dataset = text.get("dataset (test split)")
    ours = next((r for name, r in text.items() if name.endswith(" 4 steps")), None)
    tasks = results.get("constraints", {}).get("tasks", {})
    rows: list[list[str]] = []

    def bar(what: str, shown: str, met: bool) -> None:
        rows.append([what, shown, "met" if met else "**missed**"])

    if dataset and ours:
        ratio = ours["foot_skate"] / dataset["foot_skate"]
        bar(
            f"text-only foot skate within {SKATE_RATIO_BAR}x the dataset's",
            f"{ratio:.2f}x",
            ratio <= SKATE_RATIO_BAR,
        )
        chance = results["text"]["r_precision_chance"]
        r_prec = ours["r_precision_top3"]
        bar(
            "R-precision clearly above chance (2x)",
            f"{r_prec:.3f} vs chance {chance:.3f}",
            r_prec > 2 * chance,
        )
    for suffix in ("", MODEL_ONLY):
        where = f"; {suffix[2:]}" if suffix else ""
        variant = f" ({suffix[2:]})" if suffix else ""
        if "waypoints" + suffix in tasks:
            row = tasks["waypoints" + suffix]
            for key, at in (("error_m", "at the frame"), ("between_frames_error_m", "between")):
                bar(
                    f"waypoint error under {WAYPOINT_BAR_M} m ({at}{where})",
                    f"{row[key]:.3f} m",
                    row[key] < WAYPOINT_BAR_M,
                )
        if "keyframes" + suffix in tasks:
            value = tasks["keyframes" + suffix]["error_m"]
            bar(
                f"full-body keyframe error under {KEYFRAME_BAR_M} m{variant}",
                f"{value:.3f} m",
                value < KEYFRAME_BAR_M,
            )
    return ["## Acceptance bars", "", *_table(["bar", "measured", ""], rows), ""]


def write_report(results: dict[str, Any], out: Path) -> Path:
    """Writes ``out/README.md`` (and the plots next to it); returns its path."""
    out.mkdir(parents=True, exist_ok=True)
    model = results.get("model", {})
    provenance = model.get("provenance", {})
    lines = [
        "# Evaluation of the default model",
        "",
        f"Package `{model.get('path', '?')}` (checkpoint "
        f"`{provenance.get('checkpoint', '?')}`, commit `{provenance.get('commit', '?')}`), "
        "every motion generated by the C++ CLI `ardy-generate` from the package, as the "
        "plugin runs it. Regenerate with `ardy-export eval run` (see "
        "`export_tools/configs/evaluation.yaml` and the model card).",
        "",
    ]
    lines += _bars_lines(results)
    if "text" in results:
        lines += _text_lines(results["text"])
    if "constraints" in results:
        lines += _constraint_lines(results["constraints"])
    if "response" in results:
        lines += _response_lines(results["response"], out)
    if "stability" in results:
        lines += _stability_lines(results["stability"], out)
    if "contrasts" in results:
        lines += _contrast_lines(results["contrasts"], out)
    # ablations.md (ardy-export eval ablations) and notes.md (written by hand: how the
    # numbers compare with the paper's) are kept across regenerations.
    for extra in ("ablations.md", "notes.md"):
        if (out / extra).is_file():
            lines += [(out / extra).read_text(encoding="utf-8").strip(), ""]
    path = out / "README.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _pyplot():  # noqa: ANN202 (matplotlib.pyplot, a module)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plot_response(resp: dict[str, Any], path: Path) -> None:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.2), dpi=90)
    for curve in resp["curves"]:
        ax.plot(curve["t"], curve["margin"], color="tab:blue", alpha=0.35, lw=1)
    ax.axvline(4.0, color="k", lw=1, ls="--")
    ax.axhline(0.0, color="gray", lw=0.8)
    ax.set_xlabel("time (s); prompt B from 4 s")
    ax.set_ylabel("sim(B) - sim(A)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _plot_stability(st: dict[str, Any], path: Path) -> None:
    plt = _pyplot()
    trace = st["trace"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.2), dpi=90)
    a.plot(trace["t"], trace["hips_height"], lw=0.8)
    a.set_xlabel("time (s)")
    a.set_ylabel("hips height (m)")
    b.plot(trace["x"], trace["z"], lw=0.8)
    b.set_aspect("equal")
    b.set_xlabel("x (m)")
    b.set_ylabel("z (m)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _facing_front(pose: np.ndarray) -> np.ndarray:
    """One pose [J, 3] turned to face +Z over its ground point: seen from the front (from +Z),
    x runs to the viewer's right, where the character's left side is."""
    from ardy_export.data.features import heading_from_positions
    from ardy_export.data.rotations import yaw_matrix

    centred = pose - pose[0] * np.array([1.0, 0.0, 1.0])
    turn = yaw_matrix(-float(heading_from_positions(pose[None])[0]))
    return centred @ np.asarray(turn).T


SHEET_POSES = 6


def sheet_entry(positions: np.ndarray, fps: float) -> dict[str, Any]:
    """What the contact sheet draws of one rollout: ``SHEET_POSES`` evenly spaced poses and
    the root's ground path."""
    frames = np.linspace(0, len(positions) - 1, SHEET_POSES).astype(int)
    return {
        "times": (frames / fps).tolist(),
        "poses": positions[frames].tolist(),
        "path": positions[:, 0, [0, 2]].tolist(),
    }


def _plot_sheet(con: dict[str, Any], path: Path) -> None:
    """One row per prompt: poses every 1.2 s seen from the front, side by side, and the
    ground path from above."""
    plt = _pyplot()
    labels = list(con["sheet"])
    spacing = 1.1
    fig, axes = plt.subplots(
        len(labels),
        2,
        figsize=(8.0, 1.55 * len(labels)),
        dpi=80,
        gridspec_kw={"width_ratios": [5, 1]},
        squeeze=False,
    )
    for row, label in enumerate(labels):
        entry = con["sheet"][label]
        ax = axes[row, 0]
        for col, (t, shown) in enumerate(zip(entry["times"], entry["poses"], strict=True)):
            pose = _facing_front(np.asarray(shown)) + np.array([col * spacing, 0.0, 0.0])
            for j, parent in enumerate(L.PARENTS):
                if parent >= 0:
                    ax.plot(pose[[parent, j], 0], pose[[parent, j], 1], color="k", lw=1.2)
            for hand, color in (("Hand_L", "tab:red"), ("Hand_R", "tab:blue")):
                k = L.JOINT_NAMES.index(hand)
                ax.plot(pose[k, 0], pose[k, 1], "o", ms=3.5, color=color)
            ax.text(col * spacing, -0.22, f"{t:.1f} s", fontsize=6, ha="center")
        ax.set_xlim(-0.6, (len(entry["poses"]) - 1) * spacing + 0.6)
        ax.set_ylim(-0.3, 2.0)
        ax.set_aspect("equal")
        ax.axis("off")
        ax.set_title(con["prompts"][label], fontsize=8, loc="left")
        ax = axes[row, 1]
        ground = np.asarray(entry["path"])
        ax.plot(ground[:, 0], ground[:, 1], color="tab:green", lw=1)
        ax.plot(ground[0, 0], ground[0, 1], "o", ms=3, color="tab:green")
        reach = max(1.0, float(np.abs(ground).max()) * 1.1)
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=5)
    fig.text(
        0.01,
        0.002,
        "Seen from the front. Red: left hand, blue: right hand. Right column: ground path "
        "from above (x to the right, z up; the dot is the start).",
        fontsize=7,
    )
    fig.tight_layout(rect=(0, 0.012, 1, 1))
    fig.savefig(path)
    plt.close(fig)


ABLATIONS = {
    "two_stage": "two-stage denoiser (the design)",
    "one_stage": "one-stage denoiser",
    "local_root": "small tokenizer, local root in the decoder (the design)",
    "global_root": "small tokenizer, global root in the decoder",
}


def _ablation_row(
    name: str, results: dict[str, Any], steps: int = 4, text_only: bool = False
) -> list[str]:
    text = results["text"]["rows"].get(f"ours, {steps} steps", {})
    tasks = {} if text_only else results.get("constraints", {}).get("tasks", {})

    def task(key: str, field: str) -> float | None:
        # The model's own constraint following: without the runtime's root interpolation
        # (packages exported before it existed have it off in their plain rows).
        return tasks.get(key + MODEL_ONLY, tasks.get(key, {})).get(field)

    return [
        name,
        _f(text.get("foot_skate")),
        _f(text.get("r_precision_top3")),
        _f(text.get("fid")),
        _f(task("root", "foot_skate")),
        _f(task("waypoints", "between_frames_error_m")),
        _f(task("keyframes", "error_m")),
        _f(task("end_effectors", "error_m")),
        _f(task("end_effectors", "rotation_error_deg"), 1),
    ]


def write_ablation_table(runs: Path, main: Path | None, out: Path) -> Path:
    """``ablations.md`` from ``runs/eval_<name>/results.json`` (and the main evaluation's 4
    vs 10 DDIM steps rows); ``write_report`` appends it to the report."""
    import json

    header = [
        "run",
        "text skate (m/s)",
        "R-precision top-3",
        "FID",
        "skate on a root path (m/s)",
        "waypoints, between frames (m)",
        "keyframes (m)",
        "end effectors (m)",
        "end effectors (deg)",
    ]
    rows = []
    for name, what in ABLATIONS.items():
        path = runs / f"eval_{name}" / "results.json"
        if path.is_file():
            rows.append(_ablation_row(what, json.loads(path.read_text(encoding="utf-8"))))
    lines = [
        "## Ablations",
        "",
        "Each run on the same CPU budget (`scripts/run_ablations.sh`, configs in "
        "`export_tools/configs/ablations/`), on one core: a 96 x 2 denoiser trained for "
        "2,500 steps of 32 windows on the shipped model's tokenizer (stage rows), or for "
        "3,000 steps on a small 96 x 2 tokenizer of 1,500 steps of 64 (root rows, "
        "`--root`); a pair differs only in what it ablates. Evaluated like the "
        "main model with fewer rollouts (4 per label, 1 crop per label), 4 DDIM steps, "
        "constraints without the runtime's root interpolation (the model's own following). "
        "Rows missing here were not run.",
        "",
        *_table(header, rows),
        "",
    ]
    if main is not None and main.is_file():
        results = json.loads(main.read_text(encoding="utf-8"))
        step_rows = [
            _ablation_row(f"shipped model, {steps} DDIM steps", results, steps, text_only=True)
            for steps in (4, 10)
            if f"ours, {steps} steps" in results.get("text", {}).get("rows", {})
        ]
        lines += [
            "4 vs 10 diffusion steps, on the shipped model (text to motion only; the "
            "constraint tasks ran at 4 steps):",
            "",
            *_table(header, step_rows),
            "",
        ]
    out.write_text("\n".join(lines), encoding="utf-8")
    return out
