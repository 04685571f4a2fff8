"""Comparing a freshly generated fixture with the committed one.

Files that hold computed numbers (golden tensors, ONNX graphs, JSON with float results) are
compared value by value: PyTorch and ONNX Runtime legitimately differ in the last bits from
one CPU, thread count or kernel choice to another, so byte identity would fail on most
machines. Files that are pure data (vocabularies, token ids, text) stay byte-compared.

The tolerance is stated in units of float32 precision (``EPS``, 2**-23 ~ 1.19e-7): a value
``found`` matches ``expected`` when ``|found - expected| <= TOLERANCE_ULPS * EPS * (|expected|
+ scale)``, where ``scale`` is the largest magnitude in that tensor (at least 1). The term in
``|expected|`` is a relative bound; the term in ``scale`` bounds the absolute error of values
that come out of sums of larger terms (near zero the relative error of a sum is unbounded).
``TOLERANCE_ULPS = 256`` (3.1e-5 of the tensor's scale) was chosen from the differences
measured between one and two threads in PyTorch and ONNX Runtime, ONNX Runtime without graph
optimizations, and PyTorch's default (non-AVX) kernels (``ATEN_CPU_CAPABILITY=default``): the
largest was 26 float32 steps (the rollout's history after 3 windows of 4 diffusion steps);
256 leaves a factor of ten above that and is still 16 times smaller than a change of 1e-3 in
a value of magnitude 1 (tests/python/test_fixture_compare.py).

One kind of tensor is ill-conditioned by construction: rotation matrices recovered from the
6D features by Gram-Schmidt amplify their input's error by 1 / sin(angle between the two 6D
columns), which the random-weight tiny model makes large. The same settings moved them by
up to 946 steps (1.2e-4), so they get ``ROTATION_ULPS = 4096`` (4.9e-4 at scale 1): 4 times
the measured spread, and a change of 1e-3 in any entry (all lie in [-1, 1]) still fails.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import onnx
from onnx import numpy_helper

EPS = float(np.finfo(np.float32).eps)
TOLERANCE_ULPS = 256
ROTATION_ULPS = 4096
# Tensors (by name suffix) recovered through the ill-conditioned 6D -> matrix conversion.
ROTATION_TENSORS = ("/local_rotations", "/global_rotations")
REGENERATE = "scripts/make_fixtures.sh"


class FixtureMismatch(AssertionError):
    """A regenerated fixture differs from the committed one by more than the tolerance."""


def ulps_for(name: str) -> int:
    """The tolerance, in float32 steps, of the tensor called ``name``."""
    return ROTATION_ULPS if name.endswith(ROTATION_TENSORS) else TOLERANCE_ULPS


def tolerance(expected: np.ndarray, ulps: int = TOLERANCE_ULPS) -> np.ndarray:
    """The allowed absolute difference for each element of ``expected``."""
    magnitude = np.abs(expected.astype(np.float64))
    finite = magnitude[np.isfinite(magnitude)]
    scale = max(1.0, float(finite.max())) if finite.size else 1.0
    return ulps * EPS * (magnitude + scale)


def compare_arrays(name: str, found: np.ndarray, expected: np.ndarray) -> str | None:
    """None when the arrays match; else a message naming the first differing index."""
    if found.shape != expected.shape:
        return f"{name}: shape {list(found.shape)}, committed {list(expected.shape)}"
    if found.dtype.kind != expected.dtype.kind:
        return f"{name}: dtype {found.dtype}, committed {expected.dtype}"
    if expected.dtype.kind != "f":
        bad = np.flatnonzero(found.reshape(-1) != expected.reshape(-1))
    else:
        f64, e64 = found.astype(np.float64), expected.astype(np.float64)
        with np.errstate(invalid="ignore"):
            close = np.abs(f64 - e64) <= tolerance(expected, ulps_for(name))
        same_special = (np.isnan(f64) & np.isnan(e64)) | (np.isinf(e64) & (f64 == e64))
        bad = np.flatnonzero(~(close | same_special).reshape(-1))
    if bad.size == 0:
        return None
    first = int(bad[0])
    index = tuple(int(i) for i in np.unravel_index(first, expected.shape)) if expected.ndim else ()
    value, committed = found.reshape(-1)[first], expected.reshape(-1)[first]
    allowed = ""
    if expected.dtype.kind == "f":
        bound = tolerance(expected, ulps_for(name)).reshape(-1)[first]
        allowed = f", allowed difference {float(bound):.3g}"
    return (
        f"{name}{list(index)}: {value!r}, committed {committed!r} "
        f"(difference {abs(float(value) - float(committed)):.3g}{allowed}; "
        f"{bad.size} of {expected.size} values differ)"
    )


def _fail(path: Path, message: str) -> None:
    raise FixtureMismatch(f"{path} differs from a fresh generation: {message}; run {REGENERATE}")


def assert_same_tensors(
    path: Path, found: dict[str, np.ndarray], expected: dict[str, np.ndarray]
) -> None:
    """Same names in the same order, each tensor within the tolerance."""
    if list(found) != list(expected):
        missing = [n for n in expected if n not in found]
        extra = [n for n in found if n not in expected]
        _fail(path, f"tensor names differ (missing {missing}, new {extra}, or reordered)")
    for name in expected:
        message = compare_arrays(name, found[name], expected[name])
        if message is not None:
            _fail(path, message)


def _json_numbers(
    found: object, expected: object, where: str, skip: tuple[str, ...] = ()
) -> Iterator[str]:
    """Messages for every difference between two parsed JSON documents, first one first;
    keys named in ``skip`` are not compared."""
    if isinstance(expected, bool) or isinstance(found, bool):
        if found is not expected:
            yield f"{where}: {found!r}, committed {expected!r}"
    elif isinstance(expected, float) or (isinstance(expected, int) and isinstance(found, float)):
        if not isinstance(found, int | float):
            yield f"{where}: {found!r}, committed {expected!r}"
        elif not math.isclose(found, expected, rel_tol=0.0, abs_tol=0.0):
            allowed = TOLERANCE_ULPS * EPS * (abs(expected) + 1.0)
            if abs(found - expected) > allowed:
                yield (
                    f"{where}: {found!r}, committed {expected!r} (difference "
                    f"{abs(found - expected):.3g}, allowed difference {allowed:.3g})"
                )
    elif isinstance(expected, dict):
        if not isinstance(found, dict) or list(found) != list(expected):
            keys = list(found) if isinstance(found, dict) else type(found).__name__
            yield f"{where}: keys {keys}, committed {list(expected)}"
            return
        for key in expected:
            if key not in skip:
                yield from _json_numbers(found[key], expected[key], f"{where}.{key}", skip)
    elif isinstance(expected, list):
        if not isinstance(found, list) or len(found) != len(expected):
            size = len(found) if isinstance(found, list) else type(found).__name__
            yield f"{where}: length {size}, committed {len(expected)}"
            return
        if (
            expected
            and all(isinstance(v, float) for v in expected)
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in found)
        ):
            # A list of numbers is one tensor: its scale sets the absolute bound.
            message = compare_arrays(where, np.array(found, float), np.array(expected, float))
            if message is not None:
                yield message
            return
        for i, (f, e) in enumerate(zip(found, expected, strict=True)):
            yield from _json_numbers(f, e, f"{where}[{i}]", skip)
    elif found != expected:
        yield f"{where}: {found!r}, committed {expected!r}"


def assert_same_json(found_path: Path, committed_path: Path, skip: tuple[str, ...] = ()) -> None:
    """Same structure, strings and integers; floats within the tolerance. Keys in ``skip``
    (e.g. checksums of files that are themselves compared by value) are left out."""
    found = json.loads(found_path.read_text(encoding="utf-8"))
    expected = json.loads(committed_path.read_text(encoding="utf-8"))
    for message in _json_numbers(found, expected, "$", skip):
        _fail(committed_path, message)


def _tensor_protos(model: onnx.ModelProto) -> Iterator[tuple[str, onnx.TensorProto]]:
    """Every tensor stored in a graph: initializers and tensor attributes, named by place."""

    def in_graph(graph: onnx.GraphProto, prefix: str) -> Iterator[tuple[str, onnx.TensorProto]]:
        for tensor in graph.initializer:
            yield f"{prefix}initializer {tensor.name}", tensor
        for index, node in enumerate(graph.node):
            for attribute in node.attribute:
                where = f"{prefix}node {index} ({node.op_type} {node.name}).{attribute.name}"
                if attribute.HasField("t"):
                    yield where, attribute.t
                for i, tensor in enumerate(attribute.tensors):
                    yield f"{where}[{i}]", tensor
                if attribute.HasField("g"):
                    yield from in_graph(attribute.g, f"{where}/")
                for i, sub in enumerate(attribute.graphs):
                    yield from in_graph(sub, f"{where}[{i}]/")

    yield from in_graph(model.graph, "")
    for function in model.functions:
        for index, node in enumerate(function.node):
            for attribute in node.attribute:
                if attribute.HasField("t"):
                    yield f"function {function.name} node {index}.{attribute.name}", attribute.t


def assert_same_onnx(found_path: Path, committed_path: Path) -> None:
    """The graphs are identical apart from their stored tensors, which match numerically."""
    found, expected = onnx.load(str(found_path)), onnx.load(str(committed_path))
    found_tensors = dict(_tensor_protos(found))
    expected_tensors = dict(_tensor_protos(expected))
    assert_same_tensors(
        committed_path,
        {k: numpy_helper.to_array(t) for k, t in found_tensors.items()},
        {k: numpy_helper.to_array(t) for k, t in expected_tensors.items()},
    )
    for tensor in (*found_tensors.values(), *expected_tensors.values()):
        for field in ("raw_data", "float_data", "double_data", "int32_data", "int64_data"):
            tensor.ClearField(field)
    if found.SerializeToString(deterministic=True) != expected.SerializeToString(
        deterministic=True
    ):
        _fail(committed_path, "the graph's structure (nodes, names, shapes, metadata) differs")


def read_goldens(package: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """goldens.json and the tensors of goldens.bin it indexes, in the index's order."""
    index = json.loads((package / "goldens.json").read_text(encoding="utf-8"))
    blob = (package / "goldens.bin").read_bytes()
    tensors: dict[str, np.ndarray] = {}
    for name, entry in index["tensors"].items():
        dtype = np.dtype("<f4") if entry["dtype"] == "float32" else np.dtype("<i8")
        count = int(np.prod(entry["shape"])) if entry["shape"] else 1
        tensors[name] = np.frombuffer(
            blob, dtype=dtype, count=count, offset=entry["offset"]
        ).reshape(entry["shape"])
    return index, tensors


def assert_same_goldens(found_dir: Path, committed_dir: Path) -> None:
    """goldens.bin tensor by tensor (through goldens.json's index, itself compared as JSON)."""
    assert_same_json(found_dir / "goldens.json", committed_dir / "goldens.json")
    found_bin, committed_bin = found_dir / "goldens.bin", committed_dir / "goldens.bin"
    if found_bin.stat().st_size != committed_bin.stat().st_size:
        _fail(committed_bin, "the file's size differs")
    assert_same_tensors(committed_bin, read_goldens(found_dir)[1], read_goldens(committed_dir)[1])


def check_checksums(model_json: Path) -> None:
    """Every {"file"|"graph": name, "sha256": hex} entry matches the file beside model.json."""

    def entries(node: object) -> Iterator[tuple[str, str]]:
        if isinstance(node, dict):
            name = node.get("file", node.get("graph"))
            if isinstance(name, str) and "sha256" in node:
                yield name, node["sha256"]
            for value in node.values():
                yield from entries(value)
        elif isinstance(node, list):
            for value in node:
                yield from entries(value)

    found = list(entries(json.loads(model_json.read_text(encoding="utf-8"))))
    if not found:
        _fail(model_json, "no graph checksum found")
    for name, digest in found:
        actual = hashlib.sha256((model_json.parent / name).read_bytes()).hexdigest()
        if actual != digest:
            _fail(model_json, f"the sha256 of {name} is {actual}, model.json says {digest}")


BYTE_COMPARED_SUFFIXES = (".txt",)


def assert_same_fixture(found: Path, committed: Path) -> None:
    """One fixture file: by value where it holds computed numbers, by bytes where it is data."""
    if not committed.is_file():
        raise FixtureMismatch(f"{committed} is missing; run {REGENERATE}")
    if committed.suffix == ".onnx":
        assert_same_onnx(found, committed)
    elif committed.name in ("goldens.bin", "goldens.json"):
        assert_same_goldens(found.parent, committed.parent)
    elif committed.name == "model.json":
        # The graphs' checksums differ whenever their weights differ in the last bit; the
        # graphs are compared by value instead, and each checksum against its own file.
        assert_same_json(found, committed, skip=("sha256",))
        check_checksums(committed)
    elif committed.suffix == ".json":
        assert_same_json(found, committed)
    elif committed.suffix in BYTE_COMPARED_SUFFIXES:
        if found.read_bytes() != committed.read_bytes():
            _fail(committed, "the bytes differ (a data file, compared exactly)")
    else:
        raise FixtureMismatch(f"{committed}: no comparison is defined for this kind of file")
