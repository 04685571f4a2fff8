"""The model package (design.md section 6): model.json plus the ONNX graphs.

``export_package`` writes ``history.onnx``, ``goals.onnx``, ``denoiser.onnx``, ``decoder.onnx``,
``encoder.onnx``,
``text_encoder.onnx`` and ``vocab.txt`` and a ``model.json`` that carries everything the
runtime needs (nothing about the model is hard-coded in C++), then runs every graph in ONNX
Runtime against PyTorch for several history, future and token lengths and refuses the
package if they differ by more than ``PARITY_ATOL``. The tensor contract is
docs/model_contract.md.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import onnx
import onnxruntime as ort
import torch
from torch import nn

from ardy_export.data.features import FEATURE_LAYOUT, FEATURE_SIZE
from ardy_export.data.skeleton import FOOT_JOINT_NAMES
from ardy_export.models.graphs import (
    DECODER_INPUTS,
    DECODER_OUTPUTS,
    DENOISER_INPUTS,
    DENOISER_MODULE_INPUTS,
    DENOISER_OUTPUTS,
    ENCODER_INPUTS,
    ENCODER_OUTPUTS,
    GOALS_INPUTS,
    GOALS_OUTPUTS,
    HISTORY_INPUTS,
    HISTORY_OUTPUTS,
    DenoiserGraph,
    GoalsGraph,
    HistoryGraph,
    cached_inputs,
    example_denoiser_inputs,
)
from ardy_export.onnx_files import save_clean
from ardy_export.runtime_settings import (
    MAX_OUTPUT_SMOOTHING_FRAMES,
    MAX_TEXT_ONLY_GUIDANCE_SCALE,
    runtime_sampling,
)
from ardy_export.sampling.sampler import ModelBundle
from ardy_export.text.export import export_text_encoder

FORMAT = "ardy-model-package"
# 2: the history's keys and values (history.onnx) and the goals' share of the input
# projections (goals.onnx) are computed once per window (1: the denoiser took the history
# tokens and the goals and recomputed both at every call).
FORMAT_VERSION = 2
# Opset 23 has Attention and opset 20 Gelu: the exporter writes each attention and GELU as one
# node instead of about ten, which cuts ONNX Runtime's per-node cost (the denoiser graph 382
# -> 274 nodes; bench/: windows about 1.3x faster on 2 cores).
OPSET = 23
PARITY_ATOL = 1e-4
MODEL_FILE = "model.json"
GRAPH_FILES = {
    "history": "history.onnx",
    "goals": "goals.onnx",
    "denoiser": "denoiser.onnx",
    "decoder": "decoder.onnx",
    "encoder": "encoder.onnx",
}
# (history, future) lengths checked for the denoiser, token counts for the tokenizer graphs.
PARITY_HISTORY_FUTURE = ((0, 0), (1, 0), (0, 2), (3, 1), (8, 4))
PARITY_TOKENS = (1, 3, 14)


class PackageError(RuntimeError):
    """An export whose graphs do not reproduce PyTorch, or a package that cannot be built."""


def _dynamic_shapes(names: Sequence[str], axes: dict[str, dict[int, str]]) -> tuple[Any, ...]:
    return tuple(
        {i: torch.export.Dim(axis, min=0) for i, axis in axes.get(n, {}).items()} for n in names
    )


def _goals_axes() -> dict[str, dict[int, str]]:
    batch = {0: "batch"}
    future = {0: "batch", 1: "future"}
    return {
        "window_goal": batch,
        "window_goal_mask": batch,
        "future_goal": future,
        "future_goal_mask": future,
    }


def _denoiser_axes() -> dict[str, dict[int, str]]:
    batch = {0: "batch"}
    return {
        "x_t": batch,
        "step": batch,
        "text_embedding": batch,
        "text_keep": batch,
        "history_kv": {0: "batch", 4: "history"},
        "history_mask": {0: "batch", 1: "history"},
        "window_root_goal": batch,
        "window_root_mask": batch,
        "window_goal_embedding": batch,
        "future_embedding": {0: "batch", 2: "future"},
        "future_mask": {0: "batch", 1: "future"},
        "constraint_keep": batch,
    }


def _export(
    module: nn.Module,
    example: tuple[torch.Tensor, ...],
    path: Path,
    inputs: Sequence[str],
    outputs: Sequence[str],
    axes: dict[str, dict[int, str]],
) -> None:
    """One graph through the dynamo exporter, with named symbolic axes."""
    with torch.no_grad():
        program = torch.onnx.export(
            module.eval(),
            example,
            dynamo=True,
            opset_version=OPSET,
            input_names=list(inputs),
            output_names=list(outputs),
            dynamic_shapes=_dynamic_shapes(inputs, axes),
            optimize=True,
            verbose=False,
        )
    program.save(str(path), external_data=False)
    _name_symbolic_axes(path, inputs, outputs, axes)


def _name_symbolic_axes(
    path: Path, inputs: Sequence[str], outputs: Sequence[str], axes: dict[str, dict[int, str]]
) -> None:
    """The exporter names dynamic axes s0, s1, ...; give them the contract's names."""
    model = onnx.load(str(path))
    by_name = {v.name: v for v in [*model.graph.input, *model.graph.output]}
    renamed: dict[str, str] = {}
    for name in inputs:
        dims = by_name[name].type.tensor_type.shape.dim
        for index, axis in axes.get(name, {}).items():
            if dims[index].dim_param:
                renamed[dims[index].dim_param] = axis
            dims[index].dim_param = axis
    for name in outputs:
        for dim in by_name[name].type.tensor_type.shape.dim:
            if dim.dim_param in renamed:
                dim.dim_param = renamed[dim.dim_param]
    save_clean(model, path)


def _io_signature(path: Path) -> dict[str, list[dict[str, Any]]]:
    """Inputs and outputs of a saved graph as model.json lists them."""
    model = onnx.load(str(path), load_external_data=False)
    types = {onnx.TensorProto.FLOAT: "float32", onnx.TensorProto.INT64: "int64"}

    def describe(value: onnx.ValueInfoProto) -> dict[str, Any]:
        tensor = value.type.tensor_type
        shape = [d.dim_param if d.dim_param else int(d.dim_value) for d in tensor.shape.dim]
        return {"name": value.name, "dtype": types.get(tensor.elem_type, "other"), "shape": shape}

    return {
        "inputs": [describe(v) for v in model.graph.input],
        "outputs": [describe(v) for v in model.graph.output],
    }


def _run_onnx(path: Path, feeds: dict[str, np.ndarray]) -> list[np.ndarray]:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    return session.run(None, feeds)


def run_history_graph(package: Path, history: np.ndarray, history_mask: np.ndarray) -> np.ndarray:
    """history.onnx of ``package`` as the runtime calls it: not at all without history (the
    keys and values are then empty; see ``HistoryGraph``)."""
    if history.shape[1] == 0:
        shape = _io_signature(package / GRAPH_FILES["history"])["outputs"][0]["shape"]
        sizes = [history.shape[0], *(int(n) for n in shape[1:4]), 0, int(shape[5])]
        return np.zeros(sizes, dtype=np.float32)
    (keys_values,) = _run_onnx(
        package / GRAPH_FILES["history"], {"history": history, "history_mask": history_mask}
    )
    return keys_values


def run_denoiser_graphs(
    package: Path,
    feeds: dict[str, np.ndarray],
    check: dict[str, float] | None = None,
    expected: dict[str, torch.Tensor] | None = None,
    where: str = "",
) -> np.ndarray:
    """x0 of ``Denoiser.forward`` inputs (DENOISER_MODULE_INPUTS names) through the package's
    graphs as the runtime chains them: history.onnx, goals.onnx, then denoiser.onnx. With
    ``check`` and ``expected`` (the cached inputs PyTorch computes), the history and goals
    graphs' outputs are checked too and their worst errors kept in ``check``."""
    inputs = {name: feeds[name] for name in DENOISER_INPUTS if name in feeds}
    inputs["history_kv"] = run_history_graph(package, feeds["history"], feeds["history_mask"])
    goals = _run_onnx(package / GRAPH_FILES["goals"], {n: feeds[n] for n in GOALS_INPUTS})
    inputs.update(zip(GOALS_OUTPUTS, goals, strict=True))
    if check is not None and expected is not None:
        for graph, names in (("history", HISTORY_OUTPUTS), ("goals", GOALS_OUTPUTS)):
            for name in names:
                error = _check(f"{graph} ({name})", expected[name], inputs[name], where)
                check[graph] = max(check[graph], error)
    (x0,) = _run_onnx(package / GRAPH_FILES["denoiser"], inputs)
    return x0


def _check(name: str, expected: torch.Tensor, found: np.ndarray, where: str) -> float:
    error = float(np.max(np.abs(expected.numpy() - found))) if found.size else 0.0
    if tuple(found.shape) != tuple(expected.shape) or not error <= PARITY_ATOL:
        raise PackageError(
            f"{name} ({where}): ONNX Runtime gives shape {found.shape} / max abs error "
            f"{error:.3g} against PyTorch {tuple(expected.shape)} (limit {PARITY_ATOL})"
        )
    return error


def _tokenizer_examples(bundle: ModelBundle, tokens: int, seed: int) -> dict[str, torch.Tensor]:
    c = bundle.config
    g = torch.Generator().manual_seed(seed)
    return {
        "tokens": torch.randn(2, tokens, c.token_dim, generator=g),
        "prev_root": torch.randn(2, c.root_dim, generator=g),
        "prev_root_valid": torch.tensor([1.0, 0.0]),
        "body": torch.randn(2, tokens * c.patch, c.feature_dim - c.root_dim, generator=g),
    }


def export_graphs(bundle: ModelBundle, out_dir: Path) -> dict[str, float]:
    """Writes the model graphs and checks them; returns the worst error per graph."""
    out_dir.mkdir(parents=True, exist_ok=True)
    example = example_denoiser_inputs(bundle.denoiser, batch=3, history=5, future=3)
    history_axes = {0: "batch", 1: "history"}
    _export(
        HistoryGraph(bundle.denoiser),
        example[4:6],
        out_dir / GRAPH_FILES["history"],
        HISTORY_INPUTS,
        HISTORY_OUTPUTS,
        {"history": history_axes, "history_mask": history_axes},
    )
    goals_at = DENOISER_MODULE_INPUTS.index(GOALS_INPUTS[0])
    _export(
        GoalsGraph(bundle.denoiser),
        example[goals_at : goals_at + len(GOALS_INPUTS)],
        out_dir / GRAPH_FILES["goals"],
        GOALS_INPUTS,
        GOALS_OUTPUTS,
        _goals_axes(),
    )
    with torch.no_grad():
        cached_example = cached_inputs(bundle.denoiser, example)
    _export(
        DenoiserGraph(bundle.denoiser),
        cached_example,
        out_dir / GRAPH_FILES["denoiser"],
        DENOISER_INPUTS,
        DENOISER_OUTPUTS,
        _denoiser_axes(),
    )
    tok = _tokenizer_examples(bundle, 5, seed=1)
    decoder_path = out_dir / GRAPH_FILES["decoder"]
    _export(
        bundle.decoder_graph,
        (tok["tokens"], tok["prev_root"], tok["prev_root_valid"]),
        decoder_path,
        DECODER_INPUTS,
        DECODER_OUTPUTS,
        {
            "tokens": {0: "batch", 1: "tokens"},
            "prev_root": {0: "batch"},
            "prev_root_valid": {0: "batch"},
        },
    )
    encoder_path = out_dir / GRAPH_FILES["encoder"]
    _export(
        bundle.encoder_graph,
        (tok["body"],),
        encoder_path,
        ENCODER_INPUTS,
        ENCODER_OUTPUTS,
        {"body": {0: "batch", 1: "frames"}},
    )
    return check_graphs(bundle, out_dir)


def check_graphs(bundle: ModelBundle, out_dir: Path) -> dict[str, float]:
    """Every graph against PyTorch for several lengths; raises PackageError on a mismatch.

    The denoiser is checked as the runtime calls it: history.onnx, then denoiser.onnx with
    its keys and values, against the uncached ``Denoiser.forward`` (the reference); the
    history graph alone against ``history_keys_values``."""
    worst = {"history": 0.0, "goals": 0.0, "denoiser": 0.0, "decoder": 0.0, "encoder": 0.0}
    with torch.no_grad():
        for seed, (history, future) in enumerate(PARITY_HISTORY_FUTURE):
            inputs = example_denoiser_inputs(bundle.denoiser, 3, history, future, seed=seed + 10)
            # A row without constraints: the graph zeroes what the goals graph gave it.
            inputs[DENOISER_MODULE_INPUTS.index("constraint_keep")][1] = 0.0
            where = f"history {history}, future {future}"
            expected = bundle.denoiser(*inputs)
            cached = dict(zip(DENOISER_INPUTS, cached_inputs(bundle.denoiser, inputs), strict=True))
            feeds = {n: t.numpy() for n, t in zip(DENOISER_MODULE_INPUTS, inputs, strict=True)}
            found = run_denoiser_graphs(out_dir, feeds, check=worst, expected=cached, where=where)
            worst["denoiser"] = max(worst["denoiser"], _check("denoiser", expected, found, where))
        for tokens in PARITY_TOKENS:
            tok = _tokenizer_examples(bundle, tokens, seed=tokens)
            expected = bundle.decoder_graph(tok["tokens"], tok["prev_root"], tok["prev_root_valid"])
            (found,) = _run_onnx(
                out_dir / GRAPH_FILES["decoder"],
                {n: tok[n].numpy() for n in DECODER_INPUTS},
            )
            worst["decoder"] = max(
                worst["decoder"], _check("decoder", expected, found, f"{tokens} tokens")
            )
            expected = bundle.encoder_graph(tok["body"])
            (found,) = _run_onnx(out_dir / GRAPH_FILES["encoder"], {"body": tok["body"].numpy()})
            worst["encoder"] = max(
                worst["encoder"], _check("encoder", expected, found, f"{tokens} tokens")
            )
    return worst


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _git_commit() -> str:
    try:
        result = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return result.stdout.strip()


def _floats(values: np.ndarray) -> list[float]:
    return [float(v) for v in np.asarray(values, dtype=np.float32).ravel()]


def model_json(
    bundle: ModelBundle,
    out_dir: Path,
    text: dict[str, Any],
    provenance: dict[str, Any],
) -> dict[str, Any]:
    """The package description (docs/model_contract.md section 6 and design.md section 6)."""
    dc = bundle.config
    tc = bundle.tokenizer.config
    if bundle.skeleton is None:
        raise PackageError("the bundle has no skeleton; model.json needs joints and offsets")
    skeleton = bundle.skeleton
    defaults = {"steps": 4, "w_text": 2.0, "w_con": 2.0, **bundle.defaults}
    graphs: dict[str, Any] = {}
    for key, file in GRAPH_FILES.items():
        path = out_dir / file
        graphs[key] = {"file": file, "sha256": _sha256(path), **_io_signature(path)}
    graphs["text_encoder"] = {
        "file": text["graph"],
        "sha256": _sha256(out_dir / text["graph"]),
        **_io_signature(out_dir / text["graph"]),
    }
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "fps": float(tc.fps),
        "features": {
            "size": FEATURE_SIZE,
            "root": [0, dc.root_dim],
            "body": [dc.root_dim, dc.feature_dim],
            "slices": {name: list(span) for name, span in FEATURE_LAYOUT.items()},
            "contact_joints": list(FOOT_JOINT_NAMES),
        },
        "tokens": {
            "patch": dc.patch,
            "latent_dim": dc.latent_dim,
            "token_dim": dc.token_dim,
            "window": dc.window_tokens,
            "max_history": dc.max_history_tokens,
            "max_future": dc.max_future_tokens,
            "goal_dim": dc.goal_dim,
        },
        "skeleton": {
            "joints": list(skeleton.names),
            "parents": [int(p) for p in skeleton.parents],
            "rest_offsets": [_floats(row) for row in skeleton.offsets],
            "foot_joints": list(FOOT_JOINT_NAMES),
        },
        "normalization": {
            "mean": _floats(bundle.mean),
            "std": _floats(bundle.std),
            "latent_mean": _floats(bundle.latent_mean),
            "latent_std": _floats(bundle.latent_std),
        },
        "latent": {"dim": tc.latent_dim, "fsq_levels": [int(v) for v in tc.levels()]},
        "diffusion": bundle.schedule.to_dict(),
        "sampling": {
            "default_steps": int(defaults["steps"]),
            "w_text": float(defaults["w_text"]),
            "w_con": float(defaults["w_con"]),
            "decode_context_tokens": 4,
        },
        "denoiser": {
            "two_stage": bool(dc.two_stage),
            "history_self_only": bool(dc.history_self_only),
            "window_goal_input": dc.window_goal_input,
            # Sizes for the bench's FLOP counts; the runtime reads the graphs' own shapes.
            "width": int(dc.width),
            "layers": int(dc.layers),
            "heads": int(dc.heads),
            "ff_mult": int(dc.ff_mult),
            # Written only when set, so packages without it keep their bytes.
            **({"condition_modulation": True} if dc.condition_modulation else {}),
        },
        "tokenizer": {
            "root_input": tc.root_input,
            # The decoder's seam parts, written only when set (recover-checkpoint reads them).
            **({"seam_filter_frames": tc.seam_filter_frames} if tc.seam_filter_frames else {}),
            **(
                {
                    "seam_overlap_frames": tc.seam_overlap_frames,
                    "seam_overlap_contacts": tc.seam_overlap_contacts,
                }
                if tc.seam_overlap_frames
                else {}
            ),
        },
        "text": text,
        "graphs": graphs,
        "provenance": provenance,
    }


def export_package(
    bundle: ModelBundle,
    out_dir: str | Path,
    provenance: dict[str, Any] | None = None,
    tiny_text_seed: int | None = None,
    text_max_tokens: int | None = None,
    text_weights: str = "float32",
    output_smoothing_frames: float | None = None,
    interpolate_root: bool | None = None,
    path_guidance_scale: float | None = None,
    text_only_guidance_scale: float | None = None,
) -> dict[str, Any]:
    """Writes a complete, checked model package into ``out_dir``; returns its model.json.

    ``tiny_text_seed`` puts a tiny random-weight text encoder (same interface and vocabulary)
    in place of all-MiniLM-L6-v2, for test packages. ``text_weights`` is the text encoder's
    weight format (``text.export.WEIGHT_FORMATS``; "int8" for shipped packages).
    ``output_smoothing_frames`` is the runtime's output filter (src/motion_filter.hpp);
    ``interpolate_root`` makes the runtime turn sparse root targets into paths
    (``sampling.constraints.interpolate_root``); ``path_guidance_scale`` multiplies w_con in
    windows whose goals are a dense root path alone (0 < scale <= 1);
    ``text_only_guidance_scale`` multiplies w_text in windows with a prompt and no goals
    (0 < scale <= 4). Each of these left None comes from the checkpoint's sampling defaults,
    else RUNTIME_SAMPLING_DEFAULTS.
    """
    runtime = runtime_sampling(
        bundle.defaults,
        output_smoothing_frames=output_smoothing_frames,
        interpolate_root=interpolate_root,
        path_guidance_scale=path_guidance_scale,
        text_only_guidance_scale=text_only_guidance_scale,
    )
    if not 0.0 < runtime["path_guidance_scale"] <= 1.0:
        raise PackageError(
            f"path_guidance_scale is {runtime['path_guidance_scale']}, expected 0 < scale <= 1"
        )
    if not 0.0 < runtime["text_only_guidance_scale"] <= MAX_TEXT_ONLY_GUIDANCE_SCALE:
        raise PackageError(
            f"text_only_guidance_scale is {runtime['text_only_guidance_scale']}, expected "
            f"0 < scale <= {MAX_TEXT_ONLY_GUIDANCE_SCALE}"
        )
    if not 0.0 <= runtime["output_smoothing_frames"] <= MAX_OUTPUT_SMOOTHING_FRAMES:
        raise PackageError(
            f"output_smoothing_frames is {runtime['output_smoothing_frames']}, expected 0 to "
            f"{MAX_OUTPUT_SMOOTHING_FRAMES} frames"
        )
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    errors = export_graphs(bundle, out)
    text_kwargs: dict[str, Any] = {"tiny_random_seed": tiny_text_seed, "weights": text_weights}
    if text_max_tokens is not None:
        text_kwargs["max_tokens"] = text_max_tokens
    text = export_text_encoder(out, **text_kwargs)
    info = {"commit": _git_commit(), **(provenance or {}), "parity_max_abs_error": errors}
    description = model_json(bundle, out, text, info)
    description["sampling"].update(runtime)
    (out / MODEL_FILE).write_text(json.dumps(description, indent=1) + "\n", encoding="utf-8")
    return description
