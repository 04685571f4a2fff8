"""The tiny test package and its golden vectors, for the C++ runtime's parity tests.

``write_test_package`` exports a tiny random-weight model (``sampling.tiny``) with a tiny
random text encoder as a real model package, then records, with the reference
implementation:

- every graph on fixed inputs (denoiser with history and future goals, decoder, encoder,
  text encoder on prompts tokenized by the Hugging Face tokenizer);
- a multi-window rollout (the reference sampler) with a prompt change, world-space
  constraints of every kind and fixed noise: its inputs, per-window intermediate tensors
  (history tokens, goals, x0) and outputs (features, joint positions, local rotations).

Tensors go to ``goldens.bin`` (little-endian, packed) indexed by ``goldens.json``
(name -> dtype, shape, byte offset); the rollout's prompts, constraints and settings are
plain JSON in the same file. Everything is deterministic: writing twice gives the same bytes
(the tests check this).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import onnxruntime as ort
import torch

from ardy_export.models.graphs import (
    DENOISER_MODULE_INPUTS,
    example_denoiser_inputs,
)
from ardy_export.package import GRAPH_FILES, export_package, run_denoiser_graphs
from ardy_export.sampling.constraints import (
    Constraint,
    FootContact,
    JointTarget,
    PoseKeyframe,
    RootPath,
    RootWaypoint,
    window_goals,
)
from ardy_export.sampling.sampler import (
    ModelBundle,
    PromptEvent,
    RolloutConfig,
    active_prompt,
    history_tokens_for_window,
    rollout,
)
from ardy_export.sampling.tiny import random_bundle
from ardy_export.text.encoder import model_path

GOLDENS_JSON = "goldens.json"
GOLDENS_BIN = "goldens.bin"
PROMPTS = ("a person walks forward", "someone waves with the right hand")
TINY_TEXT_DIM = 8


@dataclass
class TensorWriter:
    """Collects named arrays into one binary blob with a JSON index."""

    blob: bytearray = field(default_factory=bytearray)
    index: dict[str, dict[str, Any]] = field(default_factory=dict)

    def add(self, name: str, array: np.ndarray | torch.Tensor) -> None:
        values = array.numpy() if isinstance(array, torch.Tensor) else np.asarray(array)
        if values.dtype.kind == "f":
            values = values.astype("<f4")
            dtype = "float32"
        elif values.dtype.kind in "iub":
            values = values.astype("<i8")
            dtype = "int64"
        else:
            raise TypeError(f"golden tensor {name}: unsupported dtype {values.dtype}")
        if name in self.index:
            raise KeyError(f"golden tensor {name} written twice")
        self.index[name] = {"dtype": dtype, "shape": list(values.shape), "offset": len(self.blob)}
        self.blob += np.ascontiguousarray(values).tobytes()


class OnnxTextEmbedder:
    """Prompt -> embedding with the package's text graph and the Hugging Face tokenizer."""

    def __init__(self, package_dir: Path, max_tokens: int) -> None:
        from transformers import AutoTokenizer

        self.tokenizer = AutoTokenizer.from_pretrained(str(model_path()))
        self.max_tokens = max_tokens
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        self.session = ort.InferenceSession(
            str(package_dir / "text_encoder.onnx"), options, providers=["CPUExecutionProvider"]
        )

    def tokenize(self, texts: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        encoded = self.tokenizer(
            list(texts), truncation=True, max_length=self.max_tokens, padding=True
        )
        return (
            np.asarray(encoded["input_ids"], np.int64),
            np.asarray(encoded["attention_mask"], np.int64),
        )

    def embed_batch(self, texts: Sequence[str]) -> np.ndarray:
        ids, mask = self.tokenize(texts)
        (embedding,) = self.session.run(None, {"input_ids": ids, "attention_mask": mask})
        return embedding

    def __call__(self, text: str) -> np.ndarray:
        return self.embed_batch([text])[0]


def constraint_to_json(constraint: Constraint) -> dict[str, Any]:
    """Frame-level JSON of a world-space constraint (what the C++ parity test reads).

    Values are written at the precision the reference used (float64 except the keyframe's
    float32 features), so the runtime rasterizes exactly the same numbers."""
    if isinstance(constraint, RootWaypoint):
        return {
            "type": "waypoint",
            "frame": constraint.frame,
            "x": constraint.x,
            "z": constraint.z,
            "heading": constraint.heading,
        }
    if isinstance(constraint, RootPath):
        return {
            "type": "path",
            "start_frame": constraint.start_frame,
            "positions": np.asarray(constraint.positions, np.float64).tolist(),
            "headings": None
            if constraint.headings is None
            else np.asarray(constraint.headings, np.float64).tolist(),
        }
    if isinstance(constraint, PoseKeyframe):
        return {
            "type": "keyframe",
            "frame": constraint.frame,
            "features": np.asarray(constraint.features, np.float32).tolist(),
            "include_root": constraint.include_root,
        }
    if isinstance(constraint, JointTarget):
        return {
            "type": "joint",
            "frame": constraint.frame,
            "joint": constraint.joint,
            "position": None
            if constraint.position is None
            else np.asarray(constraint.position, np.float64).tolist(),
            "rotation": None
            if constraint.rotation is None
            else np.asarray(constraint.rotation, np.float64).tolist(),
        }
    if isinstance(constraint, FootContact):
        return {
            "type": "contact",
            "start_frame": constraint.start_frame,
            "end_frame": constraint.end_frame,
            "feet": list(constraint.feet),
            "value": constraint.value,
        }
    raise TypeError(f"unknown constraint {type(constraint).__name__}")


def golden_constraints(bundle: ModelBundle) -> list[Constraint]:
    """One constraint of every kind, placed so windows see them in-window, as future goals,
    waiting beyond the horizon and dropped once passed."""
    rng = np.random.default_rng(7)
    path_frames = np.arange(50)
    path = np.stack([0.3 + 0.02 * path_frames, 1.0 + 0.05 * path_frames], axis=1)
    keyframe = bundle.mean.astype(np.float64) + 0.3 * bundle.std * rng.standard_normal(
        bundle.mean.shape
    )
    keyframe[0], keyframe[2] = 1.2, 4.0
    hand = bundle.skeleton.names.index("Hand_R") if bundle.skeleton else 12
    return [
        RootWaypoint(frame=70, x=0.5, z=2.0, heading=0.3),
        RootWaypoint(frame=30, x=0.2, z=0.8, heading=None),
        RootPath(start_frame=90, positions=path, headings=np.full(50, 0.2)),
        JointTarget(frame=100, joint=hand, position=np.array([0.3, 1.4, 0.2])),
        FootContact(start_frame=120, end_frame=140, feet=(0, 1), value=1.0),
        PoseKeyframe(frame=150, features=keyframe.astype(np.float32), include_root=True),
    ]


def _graph_goldens(
    bundle: ModelBundle, package: Path, embedder: OnnxTextEmbedder, out: TensorWriter
) -> None:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1

    def session(name: str) -> ort.InferenceSession:
        return ort.InferenceSession(
            str(package / GRAPH_FILES[name]), options, providers=["CPUExecutionProvider"]
        )

    with torch.no_grad():
        inputs = example_denoiser_inputs(bundle.denoiser, batch=3, history=5, future=3, seed=3)
        for name, tensor in zip(DENOISER_MODULE_INPUTS, inputs, strict=True):
            out.add(f"denoiser/input/{name}", tensor)
        out.add("denoiser/output/x0", bundle.denoiser(*inputs))
        g = torch.Generator().manual_seed(4)
        c = bundle.config
        tokens = torch.randn(2, 6, c.token_dim, generator=g)
        prev_root = torch.randn(2, c.root_dim, generator=g)
        prev_valid = torch.tensor([1.0, 0.0])
        out.add("decoder/input/tokens", tokens)
        out.add("decoder/input/prev_root", prev_root)
        out.add("decoder/input/prev_root_valid", prev_valid)
        out.add("decoder/output/body", bundle.decoder_graph(tokens, prev_root, prev_valid))
        body = torch.randn(2, 6 * c.patch, c.feature_dim - c.root_dim, generator=g)
        out.add("encoder/input/body", body)
        out.add("encoder/output/latent", bundle.encoder_graph(body))
    # The ONNX graphs must give the same numbers (export_package checked it); record both so
    # the C++ test can tell a graph problem from a runtime one.
    feeds = {n: t.numpy() for n, t in zip(DENOISER_MODULE_INPUTS, inputs, strict=True)}
    out.add("denoiser/onnx_output/x0", run_denoiser_graphs(package, feeds))
    ids, mask = embedder.tokenize(PROMPTS)
    out.add("text/input/input_ids", ids)
    out.add("text/input/attention_mask", mask)
    out.add("text/output/embedding", embedder.embed_batch(PROMPTS))


def _rollout_goldens(
    bundle: ModelBundle,
    embedder: OnnxTextEmbedder,
    out: TensorWriter,
    config: RolloutConfig,
    windows: int,
) -> dict[str, Any]:
    prompts = [PromptEvent(0, PROMPTS[0]), PromptEvent(45, PROMPTS[1])]
    constraints = golden_constraints(bundle)
    c, d = bundle.config.window_tokens, bundle.config.token_dim
    noise = np.random.default_rng(11).standard_normal((windows, c, d)).astype(np.float32)
    result = rollout(bundle, embedder, prompts, constraints, windows, config, noise=noise)
    out.add("rollout/noise", noise)
    out.add("rollout/output/features", result.features)
    out.add("rollout/output/tokens", result.tokens)
    if result.motion is not None:
        out.add("rollout/output/positions", result.motion.positions)
        out.add("rollout/output/local_rotations", result.motion.local_rotations)
        out.add("rollout/output/global_rotations", result.motion.global_rotations)
    # Per-window intermediates, recomputed from the committed tokens the way rollout() does.
    p = bundle.config.patch
    mean, std = bundle.mean.astype(np.float32), bundle.std.astype(np.float32)
    rd = bundle.config.root_token_dim
    world_root = result.tokens[:, :rd].reshape(-1, p, 5)
    latent = result.tokens[:, rd:]
    commit = config.commit_tokens or c
    for w, start in enumerate(result.window_starts):
        committed = w * commit
        h = min(committed, config.history_tokens)
        offset = (
            (float(world_root[committed - 1, -1, 0]), float(world_root[committed - 1, -1, 2]))
            if h
            else config.start_xz
        )
        first = committed - h
        history = history_tokens_for_window(
            world_root[first:committed], latent[first:committed], mean, std, offset
        )
        goals = window_goals(constraints, start, offset, mean, std, c, config.future_tokens, p)
        out.add(f"rollout/window{w}/history", history)
        out.add(f"rollout/window{w}/offset", np.asarray(offset, np.float32))
        out.add(f"rollout/window{w}/window_goal", goals.window_goal)
        out.add(f"rollout/window{w}/window_goal_mask", goals.window_goal_mask)
        out.add(f"rollout/window{w}/future_goal", goals.future_goal)
        out.add(f"rollout/window{w}/future_goal_mask", goals.future_goal_mask)
        out.add(f"rollout/window{w}/future_mask", goals.future_mask)
        if active_prompt(prompts, start) != result.prompts[w]:
            raise AssertionError("rollout: prompt bookkeeping disagrees with active_prompt")
    return {
        "windows": windows,
        "window_starts": result.window_starts,
        "window_prompts": result.prompts,
        "prompts": [{"frame": e.frame, "text": e.text} for e in prompts],
        "constraints": [constraint_to_json(k) for k in constraints],
        "config": {
            "steps": config.steps,
            "w_text": config.w_text,
            "w_con": config.w_con,
            "history_tokens": config.history_tokens,
            "future_tokens": config.future_tokens,
            "decode_context_tokens": config.decode_context_tokens,
            "commit_tokens": commit,
            "start_xz": list(config.start_xz),
            "root_overwrite": config.root_overwrite,
        },
    }


def write_test_package(out_dir: str | Path, seed: int = 0, windows: int = 4) -> dict[str, Any]:
    """The tiny package in ``out_dir`` plus ``goldens.json`` / ``goldens.bin`` beside it.

    PyTorch runs on one thread here: its float sums depend on the thread count. On one
    machine a regeneration is byte-identical; across CPUs the last bits may differ, and the
    suite compares the files by value within float32 tolerance
    (tests/python/fixture_compare.py; all fixtures: scripts/make_fixtures.sh).
    """
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _write_test_package(Path(out_dir), seed, windows)
    finally:
        torch.set_num_threads(threads)


def _write_test_package(out: Path, seed: int, windows: int) -> dict[str, Any]:
    # The tiny text encoder's embeddings are 8 wide: the tiny denoiser takes that size.
    bundle = random_bundle(seed=seed, text_dim=TINY_TEXT_DIM)
    description = export_package(
        bundle,
        out,
        provenance={"kind": "tiny random-weight test package", "seed": seed},
        tiny_text_seed=seed,
        output_smoothing_frames=0.0,  # the goldens are the model's raw output
        interpolate_root=False,  # and its goals the constraints as given
        path_guidance_scale=1.0,  # under the one w_con of the goldens' rollout
        text_only_guidance_scale=1.0,  # and its one w_text
    )
    # The commit differs from run to run; the golden files must not.
    description["provenance"].pop("commit", None)
    (out / "model.json").write_text(json.dumps(description, indent=1) + "\n", encoding="utf-8")
    embedder = OnnxTextEmbedder(out, int(description["text"]["max_tokens"]))
    writer = TensorWriter()
    _graph_goldens(bundle, out, embedder, writer)
    config = RolloutConfig(
        steps=4,
        w_text=2.0,
        w_con=2.0,
        history_tokens=bundle.config.max_history_tokens,
        future_tokens=bundle.config.max_future_tokens,
        decode_context_tokens=4,
        commit_tokens=8,
    )
    rollout_info = _rollout_goldens(bundle, embedder, writer, config, windows)
    index = {
        "about": "golden vectors of the tiny test package (ardy_export.goldens)",
        "prompts": list(PROMPTS),
        "rollout": rollout_info,
        "tensors": writer.index,
    }
    (out / GOLDENS_BIN).write_bytes(bytes(writer.blob))
    (out / GOLDENS_JSON).write_text(json.dumps(index, indent=1) + "\n", encoding="utf-8")
    return index
