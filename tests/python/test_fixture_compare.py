"""The numerical fixture comparison (fixture_compare): it tolerates the last-bit differences
between machines and still fails on a real change, naming the tensor, index and values."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch
from onnx import numpy_helper

from ardy_export.goldens import write_test_package
from fixture_compare import (
    EPS,
    ROTATION_ULPS,
    TOLERANCE_ULPS,
    FixtureMismatch,
    assert_same_fixture,
    assert_same_goldens,
    read_goldens,
)

COMMITTED = Path(__file__).resolve().parents[2] / "tests/data/tiny_package"


def _edited_goldens(tmp_path: Path, edit: Callable[[str, np.ndarray], None]) -> Path:
    """A copy of the committed goldens with ``edit(name, array)`` applied to every tensor."""
    out = tmp_path / "edited"
    out.mkdir()
    shutil.copy(COMMITTED / "goldens.json", out / "goldens.json")
    index, tensors = read_goldens(COMMITTED)
    blob = bytearray((COMMITTED / "goldens.bin").read_bytes())
    for name, array in tensors.items():
        changed = array.copy()
        edit(name, changed)
        offset = index["tensors"][name]["offset"]
        raw = np.ascontiguousarray(changed).tobytes()
        blob[offset : offset + len(raw)] = raw
    (out / "goldens.bin").write_bytes(bytes(blob))
    return out


# Every float tensor with values (a window's history starts empty).
FLOAT_TENSORS = [
    name
    for name, array in read_goldens(COMMITTED)[1].items()
    if array.dtype.kind == "f" and array.size
]


def test_the_tolerance_is_stated_in_float32_steps() -> None:
    assert EPS == 2.0**-23
    # 1e-3 on a value of magnitude 1 is far outside both bounds (scale 1: 2 * ulps * EPS).
    assert 2 * TOLERANCE_ULPS * EPS < 1e-3 / 10
    assert 2 * ROTATION_ULPS * EPS < 1e-3


@pytest.mark.parametrize("target", FLOAT_TENSORS)
def test_a_change_of_1e_3_in_one_golden_value_fails_and_is_named(
    tmp_path: Path, target: str
) -> None:
    """Each float tensor, changed by 1e-3 at its largest-magnitude value (the loosest spot)."""
    where: dict[str, object] = {}

    def perturb(name: str, array: np.ndarray) -> None:
        if name == target:
            flat = array.reshape(-1)
            i = int(np.argmax(np.abs(flat)))
            where["index"] = [int(k) for k in np.unravel_index(i, array.shape)]
            where["old"] = float(flat[i])
            flat[i] += np.float32(1e-3)

    edited = _edited_goldens(tmp_path, perturb)
    with pytest.raises(FixtureMismatch) as failure:
        assert_same_goldens(edited, COMMITTED)
    message = str(failure.value)
    assert message.startswith(f"{COMMITTED / 'goldens.bin'} differs from a fresh generation")
    assert f"{target}{where['index']}:" in message
    assert f"committed {np.float32(where['old'])!r}" in message
    assert "1 of " in message and "scripts/make_fixtures.sh" in message


def test_last_bit_differences_everywhere_are_tolerated(tmp_path: Path) -> None:
    """Every float value moved by up to 16 float32 steps (of its own magnitude) passes."""
    rng = np.random.default_rng(0)

    def jitter(name: str, array: np.ndarray) -> None:
        if array.dtype.kind == "f" and array.size:
            steps = rng.integers(-16, 17, size=array.shape).astype(np.float32)
            array += steps * np.spacing(np.abs(array)).astype(np.float32)

    edited = _edited_goldens(tmp_path, jitter)
    assert (edited / "goldens.bin").read_bytes() != (COMMITTED / "goldens.bin").read_bytes()
    assert_same_goldens(edited, COMMITTED)


def test_an_integer_golden_must_be_exact(tmp_path: Path) -> None:
    names = [n for n, a in read_goldens(COMMITTED)[1].items() if a.dtype.kind == "i" and a.size]
    assert names, "the goldens hold integer tensors (token ids)"

    def bump(name: str, array: np.ndarray) -> None:
        if name == names[0]:
            array.reshape(-1)[-1] += 1

    with pytest.raises(FixtureMismatch, match=re.escape(names[0])):
        assert_same_goldens(_edited_goldens(tmp_path, bump), COMMITTED)


def test_a_changed_graph_weight_or_structure_fails(tmp_path: Path) -> None:
    model = onnx.load(str(COMMITTED / "decoder.onnx"))
    initializer = max(model.graph.initializer, key=lambda t: int(np.prod(t.dims)))
    values = numpy_helper.to_array(initializer).copy()
    values.reshape(-1)[3] += np.float32(1e-3)
    initializer.CopyFrom(numpy_helper.from_array(values, initializer.name))
    onnx.save(model, str(tmp_path / "decoder.onnx"))
    with pytest.raises(FixtureMismatch, match=rf"initializer {re.escape(initializer.name)}\["):
        assert_same_fixture(tmp_path / "decoder.onnx", COMMITTED / "decoder.onnx")

    model = onnx.load(str(COMMITTED / "decoder.onnx"))
    model.graph.node[0].name += "_renamed"
    onnx.save(model, str(tmp_path / "decoder.onnx"))
    with pytest.raises(FixtureMismatch, match="structure"):
        assert_same_fixture(tmp_path / "decoder.onnx", COMMITTED / "decoder.onnx")


def test_model_json_numbers_and_checksums(tmp_path: Path) -> None:
    shutil.copytree(COMMITTED, tmp_path / "package")
    package = tmp_path / "package"
    model = json.loads((package / "model.json").read_text(encoding="utf-8"))
    model["normalization"]["std"][7] += 1e-3
    (package / "model.json").write_text(json.dumps(model, indent=1) + "\n", encoding="utf-8")
    with pytest.raises(FixtureMismatch, match=r"\$\.normalization\.std\[7\]"):
        assert_same_fixture(package / "model.json", COMMITTED / "model.json")
    # The committed model.json's checksums must describe the committed graphs.
    shutil.copy(COMMITTED / "model.json", package / "model.json")
    shutil.copy(COMMITTED / "encoder.onnx", package / "decoder.onnx")
    with pytest.raises(FixtureMismatch, match=r"sha256 of decoder\.onnx"):
        assert_same_fixture(COMMITTED / "model.json", package / "model.json")


def test_vocabulary_is_compared_by_bytes(tmp_path: Path) -> None:
    text = (COMMITTED / "vocab.txt").read_bytes()
    (tmp_path / "vocab.txt").write_bytes(text.replace(b"walk", b"wa1k", 1))
    with pytest.raises(FixtureMismatch, match="bytes differ"):
        assert_same_fixture(tmp_path / "vocab.txt", COMMITTED / "vocab.txt")


class _OtherSettings(ort.SessionOptions):
    """ONNX Runtime as another machine might run it: 2 intra-op threads, no graph fusions."""

    def __init__(self) -> None:
        super().__init__()
        super().__setattr__("graph_optimization_level", ort.GraphOptimizationLevel.ORT_DISABLE_ALL)
        super().__setattr__("intra_op_num_threads", 2)

    def __setattr__(self, name: str, value: object) -> None:
        if name not in ("intra_op_num_threads", "graph_optimization_level"):
            super().__setattr__(name, value)


def _write_with_other_settings(out: Path) -> None:
    """write_test_package with PyTorch on 2 threads (it asks for 1) and ONNX Runtime as in
    _OtherSettings; run in a process started with ATEN_CPU_CAPABILITY=default (PyTorch's
    plain kernels instead of the AVX2/AVX-512 ones this CPU would pick)."""
    set_threads = torch.set_num_threads
    torch.set_num_threads = lambda _n: set_threads(2)  # type: ignore[method-assign]
    ort.SessionOptions = _OtherSettings  # type: ignore[misc]
    write_test_package(out)


def test_a_regeneration_with_other_threads_and_kernels_passes(tmp_path: Path) -> None:
    """The acceptance of issue 13, simulated: another CPU's kernels (PyTorch's non-vector
    ones), other thread counts (PyTorch 2, ONNX Runtime 2 intra-op) and ONNX Runtime without
    graph optimizations. On the design machine this moves goldens.bin's bytes from byte 1
    (the graphs' weights differ in the last bits); compared by value it must still pass."""
    environment = {**os.environ, "ATEN_CPU_CAPABILITY": "default"}
    result = subprocess.run(
        [sys.executable, __file__, str(tmp_path)],
        env=environment,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    for path in sorted(COMMITTED.iterdir()):
        assert_same_fixture(tmp_path / path.name, path)


if __name__ == "__main__":
    _write_with_other_settings(Path(sys.argv[1]))
