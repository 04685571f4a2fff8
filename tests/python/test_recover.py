"""ardy-export recover-checkpoint: the shipped package's denoiser weights back out of its
graphs, checked against the graphs; a base of another architecture is refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.package import export_graphs
from ardy_export.recover import RecoverError, probed_goal_weights, recover_checkpoint
from ardy_export.runtime_settings import RUNTIME_SAMPLING_ABSENT, RUNTIME_SAMPLING_DEFAULTS
from ardy_export.sampling.sampler import ModelBundle

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "demo_project/addons/ardy/models/default"
BASE = ROOT / "export_tools/checkpoints/default_denoiser.pt"


def test_the_shipped_package_gives_back_weights_that_reproduce_its_graphs(tmp_path: Path) -> None:
    out = tmp_path / "recovered.pt"
    errors = recover_checkpoint(PACKAGE, BASE, out)
    assert set(errors) == {"denoiser", "decoder", "encoder"}
    assert max(errors.values()) <= 1e-4
    bundle = ModelBundle.from_checkpoint(out)
    # Every sampling setting of the package comes back, so export writes them again.
    sampling = json.loads((PACKAGE / "model.json").read_text())["sampling"]
    assert bundle.defaults == {
        "steps": sampling["default_steps"],
        **{name: sampling[name] for name in ("w_text", "w_con", *RUNTIME_SAMPLING_DEFAULTS)},
    }
    # The base is stage 2; the package is a later, fine-tuned stage: the weights moved
    # (the package may also carry weights the base has none of, its condition modulation).
    base = ModelBundle.from_checkpoint(BASE)
    recovered = bundle.denoiser.state_dict()
    moved = [
        float((recovered[name] - weights).abs().max())
        for name, weights in base.denoiser.state_dict().items()
    ]
    assert max(moved) > 1e-3
    # The goals graph read off with unit inputs is the window projection's goal columns.
    d = bundle.config.token_dim
    for stage, probed in zip(
        bundle.denoiser.stages, probed_goal_weights(PACKAGE, bundle.config), strict=True
    ):
        expected = stage.window_proj.weight.detach().numpy()[:, d:]
        assert probed.shape == expected.shape
        assert np.abs(probed - expected).max() <= 1e-6


def test_a_package_older_than_a_setting_recovers_it_as_the_runtime_reads_its_absence(
    tmp_path: Path,
) -> None:
    """A package from before a runtime setting existed sampled as the runtime reads the
    setting's absence; its recovered checkpoint keeps that, not today's export default."""
    old = tmp_path / "old"
    shutil.copytree(PACKAGE, old)
    description = json.loads((old / "model.json").read_text())
    for name in ("path_guidance_scale", "text_only_guidance_scale"):
        del description["sampling"][name]
    (old / "model.json").write_text(json.dumps(description, indent=1) + "\n")
    out = tmp_path / "recovered.pt"
    recover_checkpoint(old, BASE, out)
    defaults = ModelBundle.from_checkpoint(out).defaults
    for name in ("path_guidance_scale", "text_only_guidance_scale"):
        assert defaults[name] == RUNTIME_SAMPLING_ABSENT[name] == 1
    assert RUNTIME_SAMPLING_DEFAULTS["path_guidance_scale"] != 1  # not today's export default
    assert defaults["output_smoothing_frames"] == description["sampling"]["output_smoothing_frames"]


def test_a_base_of_another_architecture_is_refused(tmp_path: Path) -> None:
    base = torch.load(BASE, map_location="cpu", weights_only=False)
    base["denoiser_config"] = {**base["denoiser_config"], "layers": 2}
    base["ema"] = None
    other = tmp_path / "other.pt"
    out = tmp_path / "recovered.pt"
    base["model"] = Denoiser(DenoiserConfig.from_dict(base["denoiser_config"])).state_dict()
    torch.save(base, other)
    with pytest.raises(RecoverError, match="same architecture"):
        recover_checkpoint(PACKAGE, other, out)
    assert not out.exists()


def test_the_decoder_weights_come_from_the_package_not_the_base(tmp_path: Path) -> None:
    """A package whose decoder was fine-tuned after the base (stage 4) recovers from the same
    base: decoder.onnx gives the decoder half of the tokenizer, the base only the encoder."""
    import shutil

    import onnx
    from onnx import numpy_helper

    package = tmp_path / "package"
    shutil.copytree(PACKAGE, package)
    model = onnx.load(str(package / "decoder.onnx"))
    shift = {"tokenizer.dec_out.bias": 0.01, "tokenizer.decoder.norm.weight": -0.02}
    for initializer in model.graph.initializer:
        if initializer.name in shift:
            moved = numpy_helper.to_array(initializer) + np.float32(shift[initializer.name])
            initializer.CopyFrom(numpy_helper.from_array(moved, initializer.name))
    onnx.save(model, str(package / "decoder.onnx"))
    out = tmp_path / "recovered.pt"
    errors = recover_checkpoint(package, BASE, out)
    assert errors["decoder"] <= 1e-4
    recovered = ModelBundle.from_checkpoint(out).tokenizer.state_dict()
    before = recover_checkpoint(PACKAGE, BASE, tmp_path / "unchanged.pt")
    assert max(before.values()) <= 1e-4
    reference = ModelBundle.from_checkpoint(tmp_path / "unchanged.pt").tokenizer.state_dict()
    for name, delta in shift.items():
        key = name.removeprefix("tokenizer.")
        assert torch.allclose(
            recovered[key] - reference[key], torch.full_like(recovered[key], delta)
        )
    changed = [k for k in reference if not torch.equal(recovered[k], reference[k])]
    assert sorted(changed) == sorted(k.removeprefix("tokenizer.") for k in shift)


def test_a_package_trained_with_modulation_added_recovers_from_a_base_without_it(
    tmp_path: Path,
) -> None:
    """add_modulation grows a base without condition modulation; its package's graphs hold
    the modulation's weights, and the same base recovers them (the checkpoint says so)."""
    bundle = ModelBundle.from_checkpoint(BASE)
    config = DenoiserConfig.from_dict({**bundle.config.to_dict(), "condition_modulation": True})
    grown = Denoiser(config)
    grown.load_grown(bundle.denoiser.state_dict())
    torch.manual_seed(3)
    for stage in grown.stages:
        assert stage.modulation is not None
        torch.nn.init.normal_(stage.modulation.proj.weight, std=0.02)
        torch.nn.init.normal_(stage.modulation.proj.bias, std=0.02)
    bundle.denoiser = grown.eval()
    package = tmp_path / "package"
    shutil.copytree(PACKAGE, package)
    export_graphs(bundle, package)
    out = tmp_path / "recovered.pt"
    errors = recover_checkpoint(package, BASE, out)
    assert max(errors.values()) <= 1e-4
    recovered = ModelBundle.from_checkpoint(out)
    assert recovered.config.condition_modulation
    for name, value in grown.state_dict().items():
        assert torch.allclose(recovered.denoiser.state_dict()[name], value, atol=1e-6), name


def test_a_package_with_seam_parts_added_recovers_from_a_base_without_them(
    tmp_path: Path,
) -> None:
    """add_seam_filter and add_seam_overlap grow the base's decoder; its package's
    decoder.onnx holds their weights, and the same base recovers them (the checkpoint's
    tokenizer config says so)."""
    base = torch.load(BASE, map_location="cpu", weights_only=False)
    bundle = ModelBundle.from_state(base)
    grown = bundle.tokenizer.with_seam_parts(
        filter_frames=3, overlap_frames=2, overlap_contacts=False
    )
    torch.manual_seed(4)
    with torch.no_grad():
        grown.seam_filter.weight.add_(torch.randn_like(grown.seam_filter.weight) * 0.1)
        grown.dec_overlap.weight.add_(torch.randn_like(grown.dec_overlap.weight) * 0.01)
    state = {**base, "tokenizer_config": grown.config.to_dict(), "tokenizer": grown.state_dict()}
    package = tmp_path / "package"
    shutil.copytree(PACKAGE, package)
    export_graphs(ModelBundle.from_state(state), package)
    # What the export writes into model.json for such a tokenizer (the graphs cannot say
    # whether the overlap cross-fades the contact channels).
    description = json.loads((package / "model.json").read_text())
    description["tokenizer"].update(
        seam_filter_frames=3, seam_overlap_frames=2, seam_overlap_contacts=False
    )
    (package / "model.json").write_text(json.dumps(description))
    out = tmp_path / "recovered.pt"
    errors = recover_checkpoint(package, BASE, out)
    assert max(errors.values()) <= 1e-4
    recovered = ModelBundle.from_checkpoint(out).tokenizer
    config = recovered.config
    assert (config.seam_filter_frames, config.seam_overlap_frames) == (3, 2)
    assert not config.seam_overlap_contacts
    for name in ("seam_filter.weight", "dec_overlap.weight", "dec_overlap.bias"):
        assert torch.allclose(recovered.state_dict()[name], grown.state_dict()[name], atol=1e-6)
