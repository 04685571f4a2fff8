"""``ardy-export data prepare`` end to end on a small archive built from real clips."""

from __future__ import annotations

import json
import tarfile
import warnings
from pathlib import Path

import numpy as np
import pytest

from ardy_export.cli import main
from ardy_export.data.compact import pack_compact, unpack_compact
from ardy_export.data.dataset import load_clips, load_index, prepare
from ardy_export.data.features import (
    CONTACT_SLICE,
    FEATURE_SIZE,
    JOINT_POS_SLICE,
    JOINT_VEL_SLICE,
    POS_SLICE,
    ROT6D_SLICE,
)
from ardy_export.data.split import save_split
from test_data_common import CLIP_NAMES, LABEL_ONLY, dataset_root, real_clips

# Every test here runs on the real Bandai Namco clips.
pytestmark = pytest.mark.requires_data


@pytest.fixture(scope="module")
def small_source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """dataset-1.tar.xz and dataset-2.tar.xz holding the test clips (and the label file whose
    motion is missing), laid out like the real archives."""
    source = tmp_path_factory.mktemp("bandai")
    for dataset, names in CLIP_NAMES.items():
        root = dataset_root(dataset)
        with tarfile.open(source / f"{dataset}.tar.xz", "w:xz", preset=1) as archive:
            for file in ("cfg/content_label.txt", "cfg/style_label.txt"):
                archive.add(root / file, f"{root.name}/{file}")
            for name in names:
                for ext in (".bvh", ".json"):
                    archive.add(root / "data" / (name + ext), f"{root.name}/data/{name}{ext}")
            if dataset == "dataset-1":
                archive.add(
                    root / "data" / f"{LABEL_ONLY}.json", f"{root.name}/data/{LABEL_ONLY}.json"
                )
    return source


def test_prepare_writes_the_dataset_and_is_idempotent(small_source: Path, tmp_path: Path) -> None:
    out, raw = tmp_path / "processed", tmp_path / "raw"
    split = tmp_path / "split.json"
    save_split(
        [("dataset-2", "walk", "normal")], split, seed=0, test_fraction=0.1, min_train_groups=1
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = prepare(small_source, out, raw, workers=2, split_path=split, log=lambda _: None)
    assert any(LABEL_ONLY in str(w.message) for w in caught)
    assert summary["clips"] == 10
    assert summary["skipped_without_motion"] == [LABEL_ONLY]
    assert summary["per_dataset"]["dataset-2"]["test_clips"] == 1
    for file in ("clips.npz", "index.json", "labels.json", "skeleton.json", "prepare_info.json"):
        assert (out / file).is_file()
    labels = json.loads((out / "labels.json").read_text())
    assert labels["dataset-1"]["content"][6] == "bow"
    assert labels["dataset-2"]["style"][0] == "active"
    index = load_index(out)
    assert index["fps"] == 20 and index["feature_size"] == FEATURE_SIZE
    entry = next(e for e in index["clips"] if e["name"] == "dataset-1_bow_active_001")
    assert (entry["dataset"], entry["content"], entry["style"], entry["take"]) == (
        "dataset-1",
        "bow",
        "active",
        1,
    )
    clips = load_clips(out)
    assert [c.name for c in clips] == sorted(c.name for c in clips)
    expected = {c.name: c.features for c in real_clips()}
    frames = {e["name"]: e["frames"] for e in index["clips"]}
    for clip in clips:
        assert clip.features.dtype == np.float32
        assert clip.frames == frames[clip.name]
        np.testing.assert_array_equal(clip.features, expected[clip.name])
    assert [c.name for c in load_clips(out, split="test")] == ["dataset-2_walk_normal_001"]
    assert len(load_clips(out, split="train")) == 9
    # A second run finds everything up to date and changes nothing.
    stamp = (out / "clips.npz").stat().st_mtime_ns
    messages: list[str] = []
    again = prepare(small_source, out, raw, workers=1, split_path=split, log=messages.append)
    assert again == summary
    assert any("up to date" in m for m in messages)
    assert (out / "clips.npz").stat().st_mtime_ns == stamp
    # A changed split only rewrites the split column.
    save_split([], split, seed=0, test_fraction=0.1, min_train_groups=1)
    prepare(small_source, out, raw, workers=1, split_path=split, log=lambda _: None)
    assert all(c.split == "train" for c in load_clips(out))


@pytest.mark.filterwarnings("ignore:.*no motion file:UserWarning")
def test_cli_prepare(small_source: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "processed"
    code = main(
        [
            "data",
            "prepare",
            "--source",
            str(small_source),
            "--out",
            str(out),
            "--raw",
            str(tmp_path / "raw"),
            "--workers",
            "1",
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "clips: 10" in printed and "foot skate" in printed
    assert (
        main(
            [
                "data",
                "prepare",
                "--source",
                str(tmp_path / "nothing"),
                "--out",
                str(out),
                "--raw",
                str(tmp_path / "raw"),
            ]
        )
        == 1
    )
    assert "no dataset-*.tar.xz archives" in capsys.readouterr().err


def test_compact_copy_rebuilds_the_features(small_source: Path, tmp_path: Path) -> None:
    out, raw = tmp_path / "processed", tmp_path / "raw"
    split = tmp_path / "split.json"  # one held-out clip, whatever the committed split holds
    save_split(
        [("dataset-2", "walk", "normal")], split, seed=0, test_fraction=0.1, min_train_groups=1
    )
    prepare(small_source, out, raw, workers=1, split_path=split, log=lambda _: None)
    sizes = pack_compact(out, tmp_path / "compact")
    assert sizes["compact_bytes"] < 0.3 * sizes["clips_npz_bytes"]
    frames = unpack_compact(tmp_path / "compact", tmp_path / "rebuilt")
    original = {c.name: c for c in load_clips(out)}
    rebuilt = {c.name: c for c in load_clips(tmp_path / "rebuilt")}
    assert frames == sum(c.features.shape[0] for c in original.values())
    assert rebuilt.keys() == original.keys()
    for name, clip in original.items():
        again = rebuilt[name]
        assert again.split == clip.split and again.content == clip.content
        error = np.abs(again.features - clip.features)
        # float16 quaternions: rotations and positions within a few millimetres,
        # velocities (finite differences at 20 fps) within a few cm/s, contacts exact.
        assert error[:, ROT6D_SLICE].max() < 5e-3, name
        assert error[:, JOINT_POS_SLICE].max() < 5e-3, name
        assert error[:, POS_SLICE].max() < 1e-5, name
        assert error[:, JOINT_VEL_SLICE].mean() < 2e-2, name
        assert np.array_equal(again.features[:, CONTACT_SLICE], clip.features[:, CONTACT_SLICE])
    pack_compact(out, tmp_path / "train_only", split="train")
    unpack_compact(tmp_path / "train_only", tmp_path / "train_rebuilt")
    train = load_clips(tmp_path / "train_rebuilt")
    assert {c.name for c in train} == {c.name for c in original.values() if c.split == "train"}
    assert len(train) < len(original)
