"""The model package export and the committed tiny package with its golden vectors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch

from ardy_export.goldens import (
    GOLDENS_BIN,
    GOLDENS_JSON,
    TINY_TEXT_DIM,
    OnnxTextEmbedder,
    golden_constraints,
    write_test_package,
)
from ardy_export.models.graphs import (
    DECODER_INPUTS,
    DENOISER_INPUTS,
    DENOISER_MODULE_INPUTS,
    GOALS_INPUTS,
    GOALS_OUTPUTS,
    HISTORY_INPUTS,
)
from ardy_export.package import (
    GRAPH_FILES,
    PARITY_ATOL,
    PARITY_HISTORY_FUTURE,
    PackageError,
    check_graphs,
    export_graphs,
    export_package,
    model_json,
    run_denoiser_graphs,
)
from ardy_export.runtime_settings import RUNTIME_SAMPLING_DEFAULTS
from ardy_export.sampling.sampler import PromptEvent, RolloutConfig, rollout
from ardy_export.sampling.tiny import random_bundle
from fixture_compare import assert_same_fixture

COMMITTED = Path(__file__).resolve().parents[2] / "tests/data/tiny_package"


@pytest.fixture(scope="module")
def fresh_package(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tiny_package")
    write_test_package(out)
    return out


def load_goldens(package: Path) -> tuple[dict, dict[str, np.ndarray]]:
    index = json.loads((package / GOLDENS_JSON).read_text())
    blob = (package / GOLDENS_BIN).read_bytes()
    tensors = {}
    for name, entry in index["tensors"].items():
        dtype = np.float32 if entry["dtype"] == "float32" else np.int64
        count = int(np.prod(entry["shape"])) if entry["shape"] else 1
        tensors[name] = np.frombuffer(
            blob, dtype=dtype, count=count, offset=entry["offset"]
        ).reshape(entry["shape"])
    return index, tensors


def test_committed_package_and_goldens_are_what_the_exporter_writes(fresh_package: Path) -> None:
    """By value within float32 tolerance (fixture_compare): the graphs, goldens and model.json
    hold computed numbers whose last bits depend on the CPU; vocab.txt is compared by bytes."""
    files = sorted(p.name for p in fresh_package.iterdir())
    assert files == sorted(p.name for p in COMMITTED.iterdir())
    for name in files:
        assert_same_fixture(fresh_package / name, COMMITTED / name)


def test_model_json_describes_the_graphs_and_the_model() -> None:
    model = json.loads((COMMITTED / "model.json").read_text())
    assert model["format"] == "ardy-model-package" and model["format_version"] == 2
    assert model["fps"] == 20.0 and model["features"]["size"] == 258
    assert model["features"]["slices"]["rotation_6d"] == [5, 131]
    tokens = model["tokens"]
    assert tokens["token_dim"] == 5 * tokens["patch"] + tokens["latent_dim"]
    skeleton = model["skeleton"]
    assert len(skeleton["joints"]) == len(skeleton["parents"]) == len(skeleton["rest_offsets"])
    norm = model["normalization"]
    assert len(norm["mean"]) == len(norm["std"]) == 258
    assert len(norm["latent_mean"]) == tokens["latent_dim"]
    assert len(model["diffusion"]["alphas_cumprod"]) == model["diffusion"]["num_steps"]
    denoiser = model["graphs"]["denoiser"]
    assert [i["name"] for i in denoiser["inputs"]] == list(DENOISER_INPUTS)
    x_t = denoiser["inputs"][0]
    assert x_t["shape"] == ["batch", tokens["window"], tokens["token_dim"]]
    history = model["graphs"]["history"]
    assert [i["name"] for i in history["inputs"]] == list(HISTORY_INPUTS)
    assert history["inputs"][0]["shape"] == ["batch", "history", tokens["token_dim"]]
    sizes = model["denoiser"]
    stages = 2 if sizes["two_stage"] else 1
    head_dim = sizes["width"] // sizes["heads"]
    keys_values = ["batch", stages * sizes["layers"], 2, sizes["heads"], "history", head_dim]
    assert history["outputs"][0]["shape"] == keys_values
    cached = next(i for i in denoiser["inputs"] if i["name"] == "history_kv")
    assert cached["shape"] == keys_values
    goals = model["graphs"]["goals"]
    assert [i["name"] for i in goals["inputs"]] == list(GOALS_INPUTS)
    assert [o["name"] for o in goals["outputs"]] == list(GOALS_OUTPUTS)
    embedding = next(o for o in goals["outputs"] if o["name"] == "future_embedding")
    assert embedding["shape"] == ["batch", stages, "future", sizes["width"]]
    assert [i["name"] for i in model["graphs"]["decoder"]["inputs"]] == list(DECODER_INPUTS)
    assert model["graphs"]["text_encoder"]["outputs"][0]["shape"] == ["batch", TINY_TEXT_DIM]
    for key, file in GRAPH_FILES.items():
        assert model["graphs"][key]["file"] == file
    errors = model["provenance"]["parity_max_abs_error"]
    assert max(errors.values()) <= PARITY_ATOL


def test_graphs_match_pytorch_for_several_history_and_future_lengths() -> None:
    bundle = random_bundle(seed=0, text_dim=TINY_TEXT_DIM)
    errors = check_graphs(bundle, COMMITTED)
    assert len(PARITY_HISTORY_FUTURE) >= 4
    assert all(error <= PARITY_ATOL for error in errors.values()), errors


def test_graphs_of_a_denoiser_with_condition_modulation_match_pytorch(tmp_path: Path) -> None:
    """The modulation lives inside denoiser.onnx (same inputs and outputs); history.onnx
    stays unmodulated, as the cached keys and values must."""
    bundle = random_bundle(seed=1, text_dim=TINY_TEXT_DIM, layers=2, condition_modulation=True)
    errors = export_graphs(bundle, tmp_path)
    assert all(error <= PARITY_ATOL for error in errors.values()), errors
    assert all(error <= PARITY_ATOL for error in check_graphs(bundle, tmp_path).values())
    # model.json says so; a package without it keeps its model.json as before.
    committed = json.loads((COMMITTED / "model.json").read_text())
    text = committed["text"]
    (tmp_path / text["graph"]).write_bytes((COMMITTED / text["graph"]).read_bytes())
    described = model_json(bundle, tmp_path, text=text, provenance={})
    assert described["denoiser"]["condition_modulation"] is True
    assert "condition_modulation" not in committed["denoiser"]


def test_runtime_settings_come_from_the_call_then_the_checkpoint_then_the_defaults(
    tmp_path: Path,
) -> None:
    """What export writes into model.json's sampling block: a recovered or trained checkpoint
    that names a setting keeps it, an argument overrides it, the rest are the defaults."""
    bundle = random_bundle(seed=0, text_dim=TINY_TEXT_DIM)
    bundle.defaults = {"output_smoothing_frames": 0.75, "path_guidance_scale": 0.25}
    sampling = export_package(bundle, tmp_path, tiny_text_seed=0, path_guidance_scale=1.0)[
        "sampling"
    ]
    assert sampling["output_smoothing_frames"] == 0.75
    assert sampling["path_guidance_scale"] == 1.0
    assert sampling["interpolate_root"] is RUNTIME_SAMPLING_DEFAULTS["interpolate_root"]
    default_text_scale = RUNTIME_SAMPLING_DEFAULTS["text_only_guidance_scale"]
    assert sampling["text_only_guidance_scale"] == default_text_scale
    assert json.loads((tmp_path / "model.json").read_text())["sampling"] == sampling


@pytest.mark.parametrize(
    ("setting", "value", "message"),
    [
        ("path_guidance_scale", 0.0, "path_guidance_scale is 0.0, expected 0 < scale <= 1"),
        ("output_smoothing_frames", -1.0, "output_smoothing_frames is -1.0, expected 0 to 10"),
        (
            "text_only_guidance_scale",
            4.5,
            "text_only_guidance_scale is 4.5, expected 0 < scale <= 4",
        ),
    ],
)
def test_a_runtime_setting_the_runtime_would_refuse_is_refused_before_writing(
    tmp_path: Path, setting: str, value: float, message: str
) -> None:
    bundle = random_bundle(seed=0, text_dim=TINY_TEXT_DIM)
    bundle.defaults = {setting: value}
    out = tmp_path / "package"
    with pytest.raises(PackageError, match=message):
        export_package(bundle, out, tiny_text_seed=0)
    assert not out.exists()


@pytest.mark.parametrize(
    ("weights", "graph"),
    [("history_proj", "history"), ("future_proj", "goals"), ("head", "denoiser")],
)
def test_a_graph_that_differs_from_pytorch_is_refused(weights: str, graph: str) -> None:
    """Weights the committed graphs do not have: the graph that reads them is named."""
    bundle = random_bundle(seed=0, text_dim=TINY_TEXT_DIM)
    generator = torch.Generator().manual_seed(0)
    with torch.no_grad():
        for name, parameter in bundle.denoiser.named_parameters():
            if weights in name:
                # Not a uniform shift: the layer norms after a projection would undo that.
                parameter.add_(0.05 * torch.randn(parameter.shape, generator=generator))
    with pytest.raises(PackageError, match=rf"^{graph}"):
        check_graphs(bundle, COMMITTED)


class OnnxGraph:
    """An exported graph called like the PyTorch module it replaces."""

    def __init__(self, path: Path, names: tuple[str, ...], config: object = None) -> None:
        self.session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        self.names = names
        self.config = config

    def __call__(self, *tensors: torch.Tensor) -> torch.Tensor:
        feeds = {n: t.numpy() for n, t in zip(self.names, tensors, strict=True)}
        return torch.from_numpy(self.session.run(None, feeds)[0])


class OnnxDenoiser:
    """history.onnx, goals.onnx, then denoiser.onnx, called like ``Denoiser.forward`` (the
    history as tokens, the goals as given), as the runtime chains them."""

    def __init__(self, package: Path, config: object) -> None:
        self.package = package
        self.config = config

    def __call__(self, *tensors: torch.Tensor) -> torch.Tensor:
        feeds = {n: t.numpy() for n, t in zip(DENOISER_MODULE_INPUTS, tensors, strict=True)}
        return torch.from_numpy(run_denoiser_graphs(self.package, feeds))


def test_the_package_alone_reproduces_the_golden_rollout() -> None:
    """The runtime's path: ONNX graphs + the documented procedure give the golden motion."""
    index, tensors = load_goldens(COMMITTED)
    info = index["rollout"]
    bundle = random_bundle(seed=0, text_dim=TINY_TEXT_DIM)
    bundle.denoiser = OnnxDenoiser(COMMITTED, bundle.config)
    bundle.decoder_graph = OnnxGraph(COMMITTED / "decoder.onnx", DECODER_INPUTS)
    embedder = OnnxTextEmbedder(COMMITTED, 128)
    prompts = [PromptEvent(p["frame"], p["text"]) for p in info["prompts"]]
    config = RolloutConfig(**{k: v for k, v in info["config"].items() if k != "start_xz"})
    result = rollout(
        bundle,
        embedder,
        prompts,
        golden_constraints(bundle),
        info["windows"],
        config,
        noise=tensors["rollout/noise"],
    )
    expected = tensors["rollout/output/features"]
    assert result.features.shape == expected.shape
    assert np.abs(result.features - expected).max() < 1e-3
    assert result.window_starts == info["window_starts"]
    assert result.prompts == info["window_prompts"]
    # The prompt really changes the motion source: windows 0-1 and 2-3 differ in prompt.
    assert info["window_prompts"][0] != info["window_prompts"][-1]


def test_goldens_cover_every_graph_and_the_rollout_windows() -> None:
    index, tensors = load_goldens(COMMITTED)
    for name in DENOISER_MODULE_INPUTS:
        assert f"denoiser/input/{name}" in tensors
    for name in ("denoiser/output/x0", "decoder/output/body", "encoder/output/latent"):
        assert np.isfinite(tensors[name]).all()
    assert np.abs(tensors["denoiser/output/x0"] - tensors["denoiser/onnx_output/x0"]).max() < 1e-5
    windows = index["rollout"]["windows"]
    assert windows >= 3
    kinds = {c["type"] for c in index["rollout"]["constraints"]}
    assert kinds == {"waypoint", "path", "keyframe", "joint", "contact"}
    masks = [tensors[f"rollout/window{w}/window_goal_mask"].sum() for w in range(windows)]
    assert all(m > 0 for m in masks), "every window of the golden rollout is constrained"
    histories = [tensors[f"rollout/window{w}/history"].shape[0] for w in range(windows)]
    assert histories[0] == 0 and histories[-1] == index["rollout"]["config"]["history_tokens"]
