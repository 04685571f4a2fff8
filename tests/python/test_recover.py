"""ardy-export recover-checkpoint: the shipped package's denoiser weights back out of its
graphs, checked against the graphs; a base of another architecture is refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.recover import RecoverError, probed_goal_weights, recover_checkpoint
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
    # The base is stage 2; the package is the fine-tuned stage 3: the weights moved.
    base = ModelBundle.from_checkpoint(BASE)
    moved = [
        float((a - b).abs().max())
        for a, b in zip(
            bundle.denoiser.state_dict().values(), base.denoiser.state_dict().values(), strict=True
        )
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
