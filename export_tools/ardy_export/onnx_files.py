"""Saving exported ONNX graphs so the bytes depend only on the model.

The exporter records, per node, the PyTorch stack trace and module names with absolute
source paths; they would make a graph's bytes depend on where the checkout and the
virtual environment live. The runtime reads none of it.
"""

from __future__ import annotations

from pathlib import Path

import onnx


def _strip_nodes(nodes: list[onnx.NodeProto]) -> None:
    for node in nodes:
        del node.metadata_props[:]
        node.doc_string = ""
        for attribute in node.attribute:
            if attribute.HasField("g"):
                _strip_graph(attribute.g)
            for graph in attribute.graphs:
                _strip_graph(graph)


def _strip_graph(graph: onnx.GraphProto) -> None:
    graph.doc_string = ""
    del graph.metadata_props[:]
    for value in [*graph.input, *graph.output, *graph.value_info]:
        del value.metadata_props[:]
    _strip_nodes(list(graph.node))


def strip_provenance(model: onnx.ModelProto) -> onnx.ModelProto:
    """Removes the exporter's per-node doc strings and metadata (in place; returned). The
    model's own doc string, which the export writes on purpose, stays."""
    _strip_graph(model.graph)
    for function in model.functions:
        function.doc_string = ""
        del function.metadata_props[:]
        _strip_nodes(list(function.node))
    return model


def save_clean(model: onnx.ModelProto, path: str | Path) -> None:
    """Saves ``model`` (weights inline) without location-dependent metadata."""
    onnx.save_model(strip_provenance(model), str(path))
