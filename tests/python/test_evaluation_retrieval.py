"""The evaluator's motion representation and retrieval model on synthetic motion."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from ardy_export.data.skeleton import JOINT_INDEX, JOINT_NAMES, default_skeleton
from ardy_export.evaluation.motion_repr import (
    canonical_layout,
    canonical_motion,
    canonical_size,
    crop_windows,
)
from ardy_export.evaluation.retrieval import (
    Evaluator,
    EvaluatorConfig,
    build_retrieval_data,
    contrastive_loss,
    train_evaluator,
)

FPS = 20.0
KINDS = ("stand", "walk", "raise-left-hand", "turn-left")


def rotate_y(positions: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Rotate [T, J, 3] about +Y by ``angle`` (per frame or one), +Z towards +X."""
    c = np.cos(angle)[..., None] if np.ndim(angle) else np.cos(angle)
    s = np.sin(angle)[..., None] if np.ndim(angle) else np.sin(angle)
    out = positions.copy()
    out[..., 0] = c * positions[..., 0] + s * positions[..., 2]
    out[..., 2] = -s * positions[..., 0] + c * positions[..., 2]
    return out


def synthetic_motion(kind: str, frames: int, rng: np.random.Generator) -> np.ndarray:
    """World positions [T, 21, 3]: the rest pose doing ``kind``, at a random place and yaw."""
    rest = default_skeleton().rest_positions()
    rest[:, 1] += 0.05 - rest[:, 1].min()
    t = np.arange(frames) / FPS
    p = np.repeat(rest[None], frames, axis=0) + rng.normal(0.0, 0.003, (frames, len(rest), 3))
    if kind == "raise-left-hand":
        lift = 0.4 * (1.0 - np.cos(2.0 * t))[:, None]
        p[:, [JOINT_INDEX["LowerArm_L"], JOINT_INDEX["Hand_L"]], 1] += lift * [0.5, 1.0]
    if kind == "turn-left":
        p = rotate_y(p, 1.5 * t)
    if kind == "walk":
        p[..., 2] += 1.3 * t[:, None]
    p = rotate_y(p, rng.uniform(-np.pi, np.pi))
    p[..., [0, 2]] += rng.uniform(-5.0, 5.0, 2)
    return p


def test_canonical_motion_is_invariant_to_yaw_and_ground_translation() -> None:
    rng = np.random.default_rng(0)
    p = synthetic_motion("turn-left", 50, rng)
    p[..., 2] += 0.8 * np.arange(50)[:, None] / FPS
    base = canonical_motion(p, JOINT_NAMES, FPS)
    assert base.shape == (50, canonical_size(len(JOINT_NAMES))) and base.dtype == np.float32
    moved = rotate_y(p, 2.3)
    moved[..., [0, 2]] += [31.0, -17.0]
    np.testing.assert_allclose(canonical_motion(moved, JOINT_NAMES, FPS), base, atol=1e-5)


def test_canonical_motion_tells_moving_from_standing() -> None:
    rng = np.random.default_rng(1)
    layout = canonical_layout(len(JOINT_NAMES))
    walk = canonical_motion(synthetic_motion("walk", 40, rng), JOINT_NAMES, FPS)
    stand = canonical_motion(synthetic_motion("stand", 40, rng), JOINT_NAMES, FPS)
    turn = canonical_motion(synthetic_motion("turn-left", 40, rng), JOINT_NAMES, FPS)
    # forward (local +Z) at 1.3 m/s vs still; the noise adds up to ~0.1 m/s per frame
    np.testing.assert_allclose(walk[:, layout["root_velocity"]].mean(0), [0.0, 1.3], atol=0.05)
    np.testing.assert_allclose(stand[:, layout["root_velocity"]].mean(0), [0.0, 0.0], atol=0.05)
    assert turn[5:-5, layout["yaw_rate"]].mean() == pytest.approx(1.5, abs=0.05)
    assert abs(walk[5:-5, layout["yaw_rate"]].mean()) < 0.05
    assert stand[:, layout["root_height"]].mean() > 0.5


def test_crop_windows_pads_and_masks() -> None:
    frames = np.arange(10, dtype=np.float32)[:, None] * np.ones((1, 3), np.float32)
    windows, mask = crop_windows(frames, [0, 6], 6)
    assert windows.shape == (2, 6, 3)
    assert mask.tolist() == [[True] * 6, [True] * 4 + [False] * 2]
    assert windows[1, :4, 0].tolist() == [6, 7, 8, 9] and not windows[1, 4:].any()
    with pytest.raises(ValueError, match="outside"):
        crop_windows(frames, [10], 6)


def test_same_label_pairs_are_not_negatives() -> None:
    e = torch.nn.functional.normalize(torch.tensor([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), dim=-1)
    masked = contrastive_loss(e, e, torch.tensor([0, 0, 1]), 0.07)
    unmasked = contrastive_loss(e, e, torch.tensor([0, 1, 2]), 0.07)
    assert float(masked) < 1e-6 < float(unmasked)


def tiny_config(run_dir: Path, steps: int) -> dict[str, Any]:
    return {
        "run_dir": str(run_dir),
        "seed": 0,
        "motion": {"window_frames": 20, "patch_frames": 2},
        "model": {"width": 32, "layers": 1, "heads": 2, "text_hidden": 32, "dim": 16},
        "train": {
            "steps": steps,
            "batch_size": 16,
            "lr": 3e-3,
            "warmup_steps": 5,
            "log_every": 10,
            "checkpoint_every": 20,
            "threads": 1,
        },
    }


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any, list[str]]:
    rng = np.random.default_rng(2)
    bank = {k: rng.normal(size=(4, 384)).astype(np.float32) for k in KINDS}
    train = [(synthetic_motion(k, int(rng.integers(15, 40)), rng), k) for k in KINDS * 5]
    test = [(synthetic_motion(k, 30, rng), k) for k in KINDS * 2]
    cfg = EvaluatorConfig.from_run_config(tiny_config(Path("unused"), 1))
    data = build_retrieval_data(train, test, bank, JOINT_NAMES, FPS, cfg)
    run_dir = tmp_path_factory.mktemp("evaluator")
    lines: list[str] = []
    final = train_evaluator(tiny_config(run_dir, 40), log=lines.append, data=data)
    return final, data, lines


def test_training_lowers_the_loss(trained: tuple[Path, Any, list[str]]) -> None:
    final, _, lines = trained
    rows = [json.loads(line) for line in (final.parent / "metrics.jsonl").read_text().splitlines()]
    assert [r["step"] for r in rows] == [10, 20, 30, 40]
    assert rows[-1]["loss"] < 0.7 * rows[0]["loss"]
    assert any("test top-1" in line for line in lines)
    assert "R-precision" in lines[-1]


def test_embeddings_round_trip_and_shapes(
    trained: tuple[Path, Any, list[str]], tmp_path: Path
) -> None:
    final, data, _ = trained
    evaluator = Evaluator.load(final)
    rng = np.random.default_rng(5)
    motions = [synthetic_motion(k, n, rng) for k, n in zip(KINDS, (12, 20, 33, 60), strict=True)]
    emb = evaluator.embed_motion(motions)
    assert emb.shape == (4, 16) and emb.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(emb, axis=-1), 1.0, atol=1e-5)
    text = evaluator.embed_text(data.label_text[0])
    assert text.shape == (4, 16)
    np.testing.assert_allclose(np.linalg.norm(text, axis=-1), 1.0, atol=1e-5)

    evaluator.save(tmp_path / "slim.pt")
    again = Evaluator.load(tmp_path / "slim.pt")
    np.testing.assert_array_equal(again.embed_motion(motions), emb)
    np.testing.assert_array_equal(again.embed_text(data.label_text[0]), text)

    # the centre window of a 60-frame motion starts at 20; moving the motion changes nothing
    windows = evaluator.embed_motion_windows(motions[3], [0, 20, 50])
    assert windows.shape == (3, 16)
    np.testing.assert_allclose(windows[1], emb[3], atol=1e-6)
    moved = rotate_y(motions[3], 1.0) + np.array([3.0, 0.0, -2.0])
    np.testing.assert_allclose(evaluator.embed_motion([moved])[0], emb[3], atol=1e-4)


def test_resume_continues_the_run(trained: tuple[Path, Any, list[str]]) -> None:
    final, data, _ = trained
    config = tiny_config(final.parent, 50)
    resumed = train_evaluator(config, log=lambda _: None, resume=True, data=data)
    ckpt = torch.load(resumed, map_location="cpu", weights_only=False)
    assert ckpt["step"] == 50
    rows = (final.parent / "metrics.jsonl").read_text().splitlines()
    assert json.loads(rows[-1])["step"] == 50 and len(rows) == 5
