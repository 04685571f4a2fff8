"""ARDY for Godot export tools: data, training, evaluation and ONNX export."""

import os

__version__ = "0.1.0"

# ONNX Runtime's Linux wheels carry Microsoft's 1DS telemetry, which posts events from a
# background thread some seconds after the first session unless this is set before
# onnxruntime is imported (the C++ runtime sets it the same way; docs/model_contract.md).
# The tools and their tests make no network calls.
os.environ.setdefault("ORT_DISABLE_TELEMETRY", "1")
