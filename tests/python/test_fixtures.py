"""The foundation fixtures: deterministic, committed as generated, and numerically right."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest

from ardy_export import fixtures
from ardy_export.cli import main as cli_main
from fixture_compare import assert_same_fixture

ATOL = 1e-5


def _session(path: Path) -> ort.InferenceSession:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def test_regenerated_fixtures_match_the_committed_ones(
    foundation_dir: Path, tmp_path: Path
) -> None:
    """By value within float32 tolerance (fixture_compare), not by bytes."""
    written = fixtures.write_foundation_fixtures(tmp_path)
    names = sorted(path.name for path in written)
    assert names == sorted([fixtures.MLP_FILE, fixtures.MLP_GOLDEN_FILE, fixtures.TOKENS_FILE])
    for name in names:
        assert_same_fixture(tmp_path / name, foundation_dir / name)


def test_cli_writes_the_same_files(foundation_dir: Path, tmp_path: Path) -> None:
    assert cli_main(["make-fixtures", "--out", str(tmp_path)]) == 0
    for name in (fixtures.MLP_FILE, fixtures.MLP_GOLDEN_FILE, fixtures.TOKENS_FILE):
        assert_same_fixture(tmp_path / name, foundation_dir / name)


def test_models_are_valid_with_pinned_opset_and_ir(foundation_dir: Path) -> None:
    for name in (fixtures.MLP_FILE, fixtures.TOKENS_FILE):
        model = onnx.load(str(foundation_dir / name))
        onnx.checker.check_model(model, full_check=True)
        assert model.ir_version == fixtures.IR_VERSION
        assert [(o.domain, o.version) for o in model.opset_import] == [("", fixtures.OPSET)]


def test_mlp_signature(foundation_dir: Path) -> None:
    session = _session(foundation_dir / fixtures.MLP_FILE)
    inputs = session.get_inputs()
    outputs = session.get_outputs()
    assert [(i.name, i.type, i.shape) for i in inputs] == [("x", "tensor(float)", ["batch", 8])]
    assert [(o.name, o.type, o.shape) for o in outputs] == [
        ("y", "tensor(float)", ["batch", 4]),
        ("norm", "tensor(float)", ["batch"]),
    ]


def test_golden_json_matches_the_numpy_reference(foundation_dir: Path) -> None:
    golden = json.loads((foundation_dir / fixtures.MLP_GOLDEN_FILE).read_text(encoding="utf-8"))
    x_entry = golden["inputs"]["x"]
    x = np.array(x_entry["data"], dtype=np.float32).reshape(x_entry["shape"])
    np.testing.assert_array_equal(x, fixtures.mlp_inputs(fixtures.GOLDEN_BATCH))
    expected = fixtures.mlp_reference(fixtures.mlp_weights(), x)
    assert list(golden["outputs"]) == ["y", "norm"]
    for name, entry in golden["outputs"].items():
        stored = np.array(entry["data"], dtype=np.float32).reshape(entry["shape"])
        # The JSON holds each float32's shortest round-trip decimal: exact after parsing.
        np.testing.assert_array_equal(stored, expected[name])


@pytest.mark.parametrize("batch", [1, 3, 7])
def test_onnxruntime_matches_numpy(foundation_dir: Path, batch: int) -> None:
    session = _session(foundation_dir / fixtures.MLP_FILE)
    x = fixtures.mlp_inputs(batch, seed=100 + batch)
    y, norm = session.run(["y", "norm"], {"x": x})
    expected = fixtures.mlp_reference(fixtures.mlp_weights(), x)
    assert y.shape == (batch, fixtures.OUT_DIM)
    assert norm.shape == (batch,)
    assert y.dtype == np.float32
    assert norm.dtype == np.float32
    np.testing.assert_allclose(y, expected["y"], rtol=0, atol=ATOL)
    np.testing.assert_allclose(norm, expected["norm"], rtol=0, atol=ATOL)


def test_onnxruntime_matches_golden_json(foundation_dir: Path) -> None:
    golden = json.loads((foundation_dir / fixtures.MLP_GOLDEN_FILE).read_text(encoding="utf-8"))
    x_entry = golden["inputs"]["x"]
    x = np.array(x_entry["data"], dtype=np.float32).reshape(x_entry["shape"])
    session = _session(foundation_dir / fixtures.MLP_FILE)
    names = list(golden["outputs"])
    for name, value in zip(names, session.run(names, {"x": x}), strict=True):
        entry = golden["outputs"][name]
        expected = np.array(entry["data"], dtype=np.float32).reshape(entry["shape"])
        np.testing.assert_allclose(value, expected, rtol=0, atol=ATOL)


@pytest.mark.parametrize(("batch", "tokens"), [(1, 1), (2, 5), (4, 3)])
def test_tokens_graph_matches_numpy(foundation_dir: Path, batch: int, tokens: int) -> None:
    rng = np.random.default_rng(batch * 10 + tokens)
    ids = rng.integers(-(2**40), 2**40, size=(batch, tokens), dtype=np.int64)
    mask = rng.integers(0, 2, size=(batch, tokens), dtype=np.int64)
    session = _session(foundation_dir / fixtures.TOKENS_FILE)
    masked_ids, mask_sum = session.run(["masked_ids", "mask_sum"], {"ids": ids, "mask": mask})
    expected = fixtures.tokens_reference(ids, mask)
    assert masked_ids.dtype == np.int64
    np.testing.assert_array_equal(masked_ids, expected["masked_ids"])
    np.testing.assert_array_equal(mask_sum, expected["mask_sum"])
