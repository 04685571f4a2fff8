"""A denoiser checkpoint rebuilt from a model package's own graphs.

A package carries its denoiser's and its tokenizer decoder's weights in its ONNX graphs.
``recover_checkpoint`` reads them back into a ``Denoiser`` and a ``BodyTokenizer`` and
writes a slim checkpoint that ``ardy-export export`` takes, so a package whose checkpoint is
gone can be exported again (to a newer package format, say) or trained further. Everything
else (configs, the tokenizer's encoder, statistics, schedule, skeleton) comes from a base
checkpoint of the same architecture, such as the one the package was fine-tuned from (a
package whose decoder was fine-tuned with the encoder frozen, stage 4, recovers from the
same base as the one before it); the rebuilt model must reproduce the package's graphs
(denoiser, decoder, encoder) within ``PARITY_ATOL`` or nothing is written.

Weights named after their parameter are taken by name. The exporter stores the weight of a
``Linear`` as the transposed right-hand side of a ``MatMul`` under a generated name; it is
found through the ``Add`` of the same layer's named bias. Should a format version 2 graph
hold only the token part of a window projection (denoiser.onnx), its goal part (no bias)
is read off goals.onnx by feeding it one unit goal entry per window token.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import onnx
import onnxruntime as ort
import torch
from onnx import numpy_helper

from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.graphs import DENOISER_MODULE_INPUTS, example_denoiser_inputs
from ardy_export.models.tokenizer import TOKENIZER_PARTS, BodyTokenizer, TokenizerConfig
from ardy_export.package import run_denoiser_graphs
from ardy_export.runtime_settings import RUNTIME_SAMPLING_ABSENT, RUNTIME_SAMPLING_DEFAULTS
from ardy_export.sampling.sampler import ModelBundle
from ardy_export.training.common import save_checkpoint

PARITY_ATOL = 1e-4
# (history, future) lengths the rebuilt denoiser is compared at.
CHECK_LENGTHS = ((0, 0), (3, 2), (12, 6))


class RecoverError(RuntimeError):
    """The package's graphs do not give every weight, or the rebuilt model differs."""


def graph_weights(path: Path, module: str = "denoiser") -> dict[str, np.ndarray]:
    """Parameter name -> value for every weight of one exported graph that can be named;
    ``module``: the attribute the graph wrapper (models.graphs) holds the model as."""
    model = onnx.load(str(path))
    initializers = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
    prefix = module + "."
    initializers = {name.removeprefix(prefix): value for name, value in initializers.items()}
    weights = {name: value for name, value in initializers.items() if "." in name}
    consumers: dict[str, list[onnx.NodeProto]] = {}
    for node in model.graph.node:
        for name in node.input:
            consumers.setdefault(name, []).append(node)
    for node in model.graph.node:
        if node.op_type != "MatMul" or node.input[1] not in initializers:
            continue
        for add in consumers.get(node.output[0], []):
            bias = next((n.removeprefix(prefix) for n in add.input if n.endswith(".bias")), None)
            if add.op_type == "Add" and bias is not None and bias in initializers:
                weights[bias[: -len(".bias")] + ".weight"] = initializers[node.input[1]].T
    return weights


def probed_goal_weights(package: Path, config: DenoiserConfig) -> list[np.ndarray]:
    """Per stage, the goal part of ``window_proj.weight`` [W, window_goal_dim + goal_dim],
    from goals.onnx: its window_goal_embedding is linear in (goal, mask) without a bias, so
    a unit entry gives one column."""
    c = config
    pm, tokens = c.goal_dim, c.window_tokens
    inputs = 2 * pm  # goal entries, then mask entries
    batch = -(-inputs // tokens)
    goal = np.zeros((batch * tokens, 2 * pm), dtype=np.float32)
    goal[np.arange(inputs), np.arange(inputs)] = 1.0
    goal = goal.reshape(batch, tokens, 2 * pm)
    feeds = {
        "window_goal": goal[..., :pm],
        "window_goal_mask": goal[..., pm:],
        "future_goal": np.zeros((batch, 0, pm), dtype=np.float32),
        "future_goal_mask": np.zeros((batch, 0, pm), dtype=np.float32),
    }
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    session = ort.InferenceSession(
        str(package / "goals.onnx"), options, providers=["CPUExecutionProvider"]
    )
    names = [o.name for o in session.get_outputs()]
    embedding = session.run(None, feeds)[names.index("window_goal_embedding")]
    stages = embedding.shape[1]
    # Column j of the probe <- input entry j (goal entries 0..PM-1, then the mask's).
    per_entry = embedding.transpose(1, 0, 2, 3).reshape(stages, batch * tokens, -1)[:, :inputs]
    if c.window_goal_input == "full":
        keep = np.arange(inputs)
    else:  # only the body part of the goal entries reaches the projection
        entries = np.arange(pm)
        body = entries[entries % c.feature_dim >= c.root_dim]
        keep = np.concatenate((body, pm + entries))
    return [per_entry[stage][keep].T.copy() for stage in range(stages)]


def _run(path: Path, feeds: dict[str, np.ndarray]) -> np.ndarray:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    names = {i.name for i in session.get_inputs()}
    return session.run(None, {k: v for k, v in feeds.items() if k in names})[0]


def _check(name: str, expected: torch.Tensor, found: np.ndarray) -> float:
    error = float(np.max(np.abs(expected.numpy() - found))) if found.size else 0.0
    if tuple(found.shape) != tuple(expected.shape) or not error <= PARITY_ATOL:
        raise RecoverError(
            f"the rebuilt model does not reproduce the package's {name} graph "
            f"(max abs error {error:.3g}, limit {PARITY_ATOL}): is the base checkpoint of the "
            "same architecture and tokenizer?"
        )
    return error


def _denoiser_reference(package: Path, inputs: Sequence[torch.Tensor]) -> np.ndarray:
    """x0 of the package's own graphs for ``Denoiser.forward`` inputs (format 1 or 2)."""
    feeds = {
        name: tensor.numpy()
        for name, tensor in zip(
            DENOISER_MODULE_INPUTS,
            inputs,
            strict=True,
        )
    }
    if (package / "history.onnx").is_file():
        return run_denoiser_graphs(package, feeds)
    return _run(package / "denoiser.onnx", feeds)  # format version 1: one graph


def _with_package_seam_parts(
    tokenizer: BodyTokenizer, found: dict[str, np.ndarray], description: dict[str, Any]
) -> BodyTokenizer:
    """The tokenizer grown with the seam parts decoder.onnx holds and it lacks (a decoder
    fine-tuned with add_seam_filter or add_seam_overlap over a base without them); whether
    the overlap cross-fades the contact channels is in model.json (absent: it does)."""
    seam_filter = found.get("seam_filter.weight")
    overlap = found.get("dec_overlap.weight")
    return tokenizer.with_seam_parts(
        filter_frames=0 if seam_filter is None else int(seam_filter.shape[-1]),
        overlap_frames=0 if overlap is None else int(overlap.shape[0]) // tokenizer.config.body_dim,
        overlap_contacts=bool(description.get("tokenizer", {}).get("seam_overlap_contacts", True)),
    )


def _with_package_decoder(
    package: Path, tokenizer_state: dict[str, torch.Tensor], found: dict[str, np.ndarray]
) -> dict[str, torch.Tensor]:
    """The tokenizer's state with every decoder parameter taken from decoder.onnx's weights
    (``found``)."""
    decoder = tuple(module + "." for module in TOKENIZER_PARTS["decoder"])
    names = [name for name in tokenizer_state if name.startswith(decoder)]
    missing = [name for name in names if name not in found]
    if missing:
        raise RecoverError(
            f"{package}: decoder.onnx holds no weight for {len(missing)} decoder parameters "
            f"(first: {missing[0]}); is the base checkpoint of the same architecture?"
        )
    state = dict(tokenizer_state)
    for name in names:
        if tuple(found[name].shape) != tuple(state[name].shape):
            raise RecoverError(
                f"{package}: tokenizer {name} is {tuple(found[name].shape)} in decoder.onnx, "
                f"{tuple(state[name].shape)} in the base checkpoint's architecture"
            )
        state[name] = torch.from_numpy(np.array(found[name]))
    return state


def recover_checkpoint(package: Path, base_checkpoint: Path, out: Path) -> dict[str, float]:
    """Writes ``out`` (slim checkpoint: base + the package's denoiser weights, decoder weights
    and sampling defaults); returns the largest difference to each of the package's graphs."""
    description = json.loads((package / "model.json").read_text(encoding="utf-8"))
    base = torch.load(base_checkpoint, map_location="cpu", weights_only=False)
    decoder_weights = graph_weights(package / "decoder.onnx", module="tokenizer")
    base_tokenizer = BodyTokenizer(TokenizerConfig.from_dict(base["tokenizer_config"]))
    base_tokenizer.load_state_dict(base["tokenizer"])
    grown = _with_package_seam_parts(base_tokenizer, decoder_weights, description)
    base = {**base, "tokenizer_config": grown.config.to_dict(), "tokenizer": grown.state_dict()}
    bundle = ModelBundle.from_state(base)
    found: dict[str, np.ndarray] = {}
    for graph in ("history.onnx", "goals.onnx", "denoiser.onnx"):
        if (package / graph).is_file():
            found.update(graph_weights(package / graph))
    if not bundle.config.condition_modulation and any(".modulation." in n for n in found):
        # Trained with condition modulation added to a base without it (add_modulation).
        config = DenoiserConfig.from_dict({**bundle.config.to_dict(), "condition_modulation": True})
        bundle.denoiser = Denoiser(config).eval()
    state = bundle.denoiser.state_dict()
    prefixes = ["root_stage", "body_stage"] if bundle.config.two_stage else ["joint_stage"]
    token_dim = bundle.config.token_dim
    split = [f"{prefix}.window_proj.weight" for prefix in prefixes]
    if all(found.get(name, np.zeros((0, 0))).shape[1:] == (token_dim,) for name in split):
        # Format 2 with the window projection stored split: the token part (denoiser.onnx)
        # and the goal part (goals.onnx).
        goal_parts = probed_goal_weights(package, bundle.config)
        for name, goal_part in zip(split, goal_parts, strict=True):
            found[name] = np.concatenate((found[name], goal_part), axis=1)
    extra = [name for name in found if name.split(".")[0] in prefixes and name not in state]
    if extra:
        raise RecoverError(
            f"{package}: the graphs hold {len(extra)} weights that the base checkpoint's "
            f"architecture does not have (first: {extra[0]}); is the base of the same "
            "architecture?"
        )
    missing = [name for name in state if name not in found]
    if missing:
        raise RecoverError(
            f"{package}: the graphs hold no weight for {len(missing)} denoiser parameters "
            f"(first: {missing[0]}); is the base checkpoint of the same architecture?"
        )
    for name, value in state.items():
        if tuple(found[name].shape) != tuple(value.shape):
            raise RecoverError(
                f"{package}: {name} is {tuple(found[name].shape)} in the graphs, "
                f"{tuple(value.shape)} in the base checkpoint's architecture"
            )
    weights = {name: torch.from_numpy(np.array(found[name])) for name in state}
    bundle.denoiser.load_state_dict(weights)
    tokenizer_state = _with_package_decoder(package, bundle.tokenizer.state_dict(), decoder_weights)
    bundle.tokenizer.load_state_dict(tokenizer_state)
    errors = {"denoiser": 0.0, "decoder": 0.0, "encoder": 0.0}
    with torch.no_grad():
        for seed, (history, future) in enumerate(CHECK_LENGTHS):
            inputs = example_denoiser_inputs(bundle.denoiser, 3, history, future, seed=seed)
            reference = _denoiser_reference(package, inputs)
            error = _check("denoiser", bundle.denoiser(*inputs), reference)
            errors["denoiser"] = max(errors["denoiser"], error)
        g = torch.Generator().manual_seed(7)
        c = bundle.config
        tokens = torch.randn(2, 6, c.token_dim, generator=g)
        prev_root = torch.randn(2, c.root_dim, generator=g)
        prev_valid = torch.tensor([1.0, 0.0])
        feeds = {
            "tokens": tokens.numpy(),
            "prev_root": prev_root.numpy(),
            "prev_root_valid": prev_valid.numpy(),
        }
        errors["decoder"] = _check(
            "decoder",
            bundle.decoder_graph(tokens, prev_root, prev_valid),
            _run(package / "decoder.onnx", feeds),
        )
        body = torch.randn(2, 6 * c.patch, c.feature_dim - c.root_dim, generator=g)
        errors["encoder"] = _check(
            "encoder",
            bundle.encoder_graph(body),
            _run(package / "encoder.onnx", {"body": body.numpy()}),
        )
    sampling = description.get("sampling", {})
    defaults = {
        "steps": int(sampling.get("default_steps", 4)),
        "w_text": float(sampling.get("w_text", 2.0)),
        "w_con": float(sampling.get("w_con", 2.0)),
        # The runtime's settings too, so that exporting the recovered checkpoint samples as
        # the package did: a setting the package lacks as the runtime reads its absence.
        **{
            name: sampling.get(name, RUNTIME_SAMPLING_ABSENT[name])
            for name in RUNTIME_SAMPLING_DEFAULTS
        },
    }
    recovered: dict[str, Any] = {
        key: value for key, value in base.items() if key not in ("model", "optimizer", "rng")
    }
    recovered["ema"] = weights
    recovered["denoiser_config"] = bundle.config.to_dict()
    recovered["tokenizer"] = tokenizer_state
    recovered["tokenizer_config"] = bundle.tokenizer.config.to_dict()
    recovered["sampling_defaults"] = defaults
    recovered["recovered_from"] = {
        "package": str(package),
        "base_checkpoint": str(base_checkpoint),
        "max_abs_error": errors,
    }
    save_checkpoint(out, recovered)
    return errors
