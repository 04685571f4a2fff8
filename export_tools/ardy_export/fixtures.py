"""Tiny deterministic ONNX graphs and golden vectors for the runtime's foundation tests.

Built with ``onnx.helper`` only (no torch), so they depend on nothing but numpy and onnx.
Two graphs are written to ``tests/data/foundation/``:

* ``mlp.onnx``: ``x`` float32 [batch, 8] -> ``y = tanh(x @ W1 + b1) @ W2 + b2`` float32
  [batch, 4] and ``norm = ReduceSumSquare(y, axis=-1)`` float32 [batch]. Its golden vectors
  (``mlp_golden.json``) are computed in float64 numpy, independently of any ONNX runtime.
* ``tokens.onnx``: two int64 inputs ``ids`` and ``mask`` [batch, tokens] -> ``masked_ids =
  ids * mask`` int64 and ``mask_sum = float(sum(mask, axis=1))`` float32 [batch]. It covers
  the int64 path and symbolic axes shared by two inputs; its expected values are trivial
  integer arithmetic.

Regenerating gives byte-identical files: fixed seeds, fixed producer fields, raw initializers.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

SEED = 1729
IN_DIM = 8
HIDDEN_DIM = 16
OUT_DIM = 4
GOLDEN_BATCH = 3
OPSET = 17
# IR version 8 is the one released with opset 17. Pinning it (instead of the onnx package's
# newest IR) keeps the bytes independent of the onnx version and loadable by any recent runtime.
IR_VERSION = 8
PRODUCER = "ardy_export.fixtures"
PRODUCER_VERSION = "1"

MLP_FILE = "mlp.onnx"
MLP_GOLDEN_FILE = "mlp_golden.json"
TOKENS_FILE = "tokens.onnx"


@dataclass(frozen=True)
class MlpWeights:
    """The MLP's parameters, float32 as stored in the graph."""

    w1: np.ndarray  # [IN_DIM, HIDDEN_DIM]
    b1: np.ndarray  # [HIDDEN_DIM]
    w2: np.ndarray  # [HIDDEN_DIM, OUT_DIM]
    b2: np.ndarray  # [OUT_DIM]


def mlp_weights(seed: int = SEED) -> MlpWeights:
    """Deterministic weights, scaled like a fan-in initialisation so outputs stay near 1."""
    rng = np.random.default_rng(seed)
    w1 = rng.standard_normal((IN_DIM, HIDDEN_DIM)) / np.sqrt(IN_DIM)
    b1 = 0.1 * rng.standard_normal(HIDDEN_DIM)
    w2 = rng.standard_normal((HIDDEN_DIM, OUT_DIM)) / np.sqrt(HIDDEN_DIM)
    b2 = 0.1 * rng.standard_normal(OUT_DIM)
    return MlpWeights(
        w1=w1.astype(np.float32),
        b1=b1.astype(np.float32),
        w2=w2.astype(np.float32),
        b2=b2.astype(np.float32),
    )


def mlp_inputs(batch: int, seed: int = SEED + 1) -> np.ndarray:
    """Deterministic float32 inputs [batch, IN_DIM]."""
    rng = np.random.default_rng(seed)
    return (1.5 * rng.standard_normal((batch, IN_DIM))).astype(np.float32)


def mlp_reference(weights: MlpWeights, x: np.ndarray) -> dict[str, np.ndarray]:
    """The MLP computed in float64 numpy from the float32 parameters, cast to float32."""
    x64 = np.asarray(x, dtype=np.float64)
    hidden = np.tanh(x64 @ weights.w1.astype(np.float64) + weights.b1.astype(np.float64))
    y = hidden @ weights.w2.astype(np.float64) + weights.b2.astype(np.float64)
    norm = np.sum(y * y, axis=-1)
    return {"y": y.astype(np.float32), "norm": norm.astype(np.float32)}


def tokens_reference(ids: np.ndarray, mask: np.ndarray) -> dict[str, np.ndarray]:
    """What tokens.onnx computes, in numpy."""
    ids = np.asarray(ids, dtype=np.int64)
    mask = np.asarray(mask, dtype=np.int64)
    return {
        "masked_ids": ids * mask,
        "mask_sum": mask.sum(axis=1).astype(np.float32),
    }


def _finish_model(graph: onnx.GraphProto) -> onnx.ModelProto:
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name=PRODUCER,
        producer_version=PRODUCER_VERSION,
    )
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model, full_check=True)
    return model


def build_mlp_model(weights: MlpWeights) -> onnx.ModelProto:
    """mlp.onnx: x [batch, 8] -> y [batch, 4], norm [batch]."""
    initializers = [
        numpy_helper.from_array(weights.w1, "W1"),
        numpy_helper.from_array(weights.b1, "b1"),
        numpy_helper.from_array(weights.w2, "W2"),
        numpy_helper.from_array(weights.b2, "b2"),
    ]
    nodes = [
        helper.make_node("MatMul", ["x", "W1"], ["h_pre"], name="matmul1"),
        helper.make_node("Add", ["h_pre", "b1"], ["h_biased"], name="add1"),
        helper.make_node("Tanh", ["h_biased"], ["h"], name="tanh"),
        helper.make_node("MatMul", ["h", "W2"], ["y_pre"], name="matmul2"),
        helper.make_node("Add", ["y_pre", "b2"], ["y"], name="add2"),
        helper.make_node("ReduceSumSquare", ["y"], ["norm"], name="norm", axes=[-1], keepdims=0),
    ]
    graph = helper.make_graph(
        nodes,
        "ardy_foundation_mlp",
        inputs=[helper.make_tensor_value_info("x", TensorProto.FLOAT, ["batch", IN_DIM])],
        outputs=[
            helper.make_tensor_value_info("y", TensorProto.FLOAT, ["batch", OUT_DIM]),
            helper.make_tensor_value_info("norm", TensorProto.FLOAT, ["batch"]),
        ],
        initializer=initializers,
    )
    return _finish_model(graph)


def build_tokens_model() -> onnx.ModelProto:
    """tokens.onnx: ids, mask int64 [batch, tokens] -> masked_ids int64, mask_sum float32."""
    axes = numpy_helper.from_array(np.array([1], dtype=np.int64), "sum_axes")
    nodes = [
        helper.make_node("Mul", ["ids", "mask"], ["masked_ids"], name="mask_ids"),
        helper.make_node(
            "ReduceSum", ["mask", "sum_axes"], ["mask_count"], name="count", keepdims=0
        ),
        helper.make_node("Cast", ["mask_count"], ["mask_sum"], name="cast", to=TensorProto.FLOAT),
    ]
    token_shape: list[str | int] = ["batch", "tokens"]
    graph = helper.make_graph(
        nodes,
        "ardy_foundation_tokens",
        inputs=[
            helper.make_tensor_value_info("ids", TensorProto.INT64, token_shape),
            helper.make_tensor_value_info("mask", TensorProto.INT64, token_shape),
        ],
        outputs=[
            helper.make_tensor_value_info("masked_ids", TensorProto.INT64, token_shape),
            helper.make_tensor_value_info("mask_sum", TensorProto.FLOAT, ["batch"]),
        ],
        initializer=[axes],
    )
    return _finish_model(graph)


def _float_list(values: np.ndarray) -> list[float]:
    # str() of a float32 is its shortest round-trip decimal, so the JSON stays short and a
    # reader parsing it as float32 gets the exact value back.
    return [float(str(v)) for v in np.asarray(values, dtype=np.float32).ravel()]


def _tensor_json(values: np.ndarray) -> dict[str, Any]:
    return {"shape": list(values.shape), "data": _float_list(values)}


def golden_json(inputs: dict[str, np.ndarray], outputs: dict[str, np.ndarray]) -> str:
    """Golden vectors as JSON, one line per tensor so diffs stay readable."""

    def block(tensors: dict[str, np.ndarray]) -> str:
        lines = [
            f"    {json.dumps(name)}: {json.dumps(_tensor_json(value))}"
            for name, value in tensors.items()
        ]
        return "{\n" + ",\n".join(lines) + "\n  }"

    return (
        "{\n"
        f'  "model": {json.dumps(MLP_FILE)},\n'
        f'  "inputs": {block(inputs)},\n'
        f'  "outputs": {block(outputs)}\n'
        "}\n"
    )


def write_foundation_fixtures(out_dir: Path) -> list[Path]:
    """Write mlp.onnx, mlp_golden.json and tokens.onnx into out_dir; return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    weights = mlp_weights()
    x = mlp_inputs(GOLDEN_BATCH)

    mlp_path = out_dir / MLP_FILE
    mlp_path.write_bytes(build_mlp_model(weights).SerializeToString(deterministic=True))

    golden_path = out_dir / MLP_GOLDEN_FILE
    golden_path.write_text(golden_json({"x": x}, mlp_reference(weights, x)), encoding="utf-8")

    tokens_path = out_dir / TOKENS_FILE
    tokens_path.write_bytes(build_tokens_model().SerializeToString(deterministic=True))
    return [mlp_path, golden_path, tokens_path]
