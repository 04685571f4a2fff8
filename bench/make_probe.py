"""The bench's peak probe: one ONNX graph, c = a @ b with a [N, N] an input and b [N, N] a
constant, so ardy-bench can measure the single-precision rate ONNX Runtime's matrix product
reaches on this machine with the bench's threads (the "limit" its GFLOP/s are compared with).

    .venv/bin/python bench/make_probe.py --out build/bench_results/matmul_probe.onnx
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

SIZE = 1024
OPSET = 18


def probe_model(size: int) -> onnx.ModelProto:
    rng = np.random.default_rng(0)
    b = numpy_helper.from_array(
        rng.standard_normal((size, size)).astype(np.float32), name="b"
    )
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["a", "b"], ["c"])],
        "matmul_probe",
        [helper.make_tensor_value_info("a", TensorProto.FLOAT, [size, size])],
        [helper.make_tensor_value_info("c", TensorProto.FLOAT, [size, size])],
        initializer=[b],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])
    model.ir_version = 9
    onnx.checker.check_model(model)
    return model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--size", type=int, default=SIZE)
    args = parser.parse_args()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(probe_model(args.size), str(args.out))


if __name__ == "__main__":
    main()
