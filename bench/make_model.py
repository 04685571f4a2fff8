"""A random-weight model package of the default model size, for timing.

Sizes come from the training configs (export_tools/configs/tokenizer.yaml and
denoiser.yaml, the "model" sections), so the benchmark follows them; weights are random
(timing does not depend on them) and statistics synthetic. Writes the package
(ardy_export.package.export_package) and ``reference.pt``, a checkpoint in the format of
``ModelBundle.from_checkpoint`` with the same weights, for the PyTorch reference timing.

    .venv/bin/python bench/make_model.py --out build/bench_model [--tiny-text]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "export_tools"))

from ardy_export.diffusion import DiffusionSchedule
from ardy_export.goldens import TINY_TEXT_DIM
from ardy_export.models import layout as L
from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig
from ardy_export.package import export_package
from ardy_export.sampling.sampler import ModelBundle
from ardy_export.sampling.tiny import synthetic_stats
from ardy_export.training import synthetic

TOKENIZER_KEYS = (
    "latent_dim",
    "fsq_levels",
    "patch",
    "width",
    "layers",
    "heads",
    "ff_mult",
    "root_input",
)
DENOISER_KEYS = (
    "window_tokens",
    "max_history_tokens",
    "max_future_tokens",
    "diffusion_steps",
    "width",
    "layers",
    "heads",
    "ff_mult",
    "two_stage",
    "history_self_only",
)


def model_section(path: Path, keys: tuple[str, ...]) -> dict:
    with path.open(encoding="utf-8") as handle:
        model = (yaml.safe_load(handle) or {}).get("model", {})
    return {k: model[k] for k in keys if k in model}


def build(seed: int, text_dim: int) -> tuple[ModelBundle, dict]:
    torch.manual_seed(seed)
    tok_size = model_section(
        ROOT / "export_tools/configs/tokenizer.yaml", TOKENIZER_KEYS
    )
    den_size = model_section(ROOT / "export_tools/configs/denoiser.yaml", DENOISER_KEYS)
    tcfg = TokenizerConfig(body_dim=L.BODY_DIM, **tok_size)
    dcfg = DenoiserConfig(
        feature_dim=L.FEATURE_SIZE,
        latent_dim=tcfg.latent_dim,
        text_dim=text_dim,
        **den_size,
    )
    tok = BodyTokenizer(tcfg)
    mean, std = synthetic_stats()
    tok.set_statistics(
        torch.from_numpy(mean[:5]),
        torch.from_numpy(std[:5]),
        torch.tensor([0.0, 0.0, 1.0, 0.9]),
        torch.tensor([1.0, 0.5, 1.0, 0.05]),
    )
    den = Denoiser(dcfg)
    rng = np.random.default_rng(seed)
    bundle = ModelBundle(
        tokenizer=tok.eval(),
        denoiser=den.eval(),
        schedule=DiffusionSchedule.cosine(dcfg.diffusion_steps),
        mean=mean,
        std=std,
        latent_mean=(0.1 * rng.standard_normal(dcfg.latent_dim)).astype(np.float32),
        latent_std=(0.5 + rng.random(dcfg.latent_dim)).astype(np.float32),
        skeleton=synthetic.synthetic_skeleton(),
    )
    sizes = {"tokenizer": tok_size, "denoiser": den_size, "text_dim": text_dim}
    return bundle, sizes


def checkpoint(bundle: ModelBundle) -> dict:
    """The keys ModelBundle.from_state reads."""
    s = bundle.skeleton
    assert s is not None
    return {
        "kind": "denoiser",
        "tokenizer_config": bundle.tokenizer.config.__dict__.copy(),
        "tokenizer": bundle.tokenizer.state_dict(),
        "denoiser_config": bundle.denoiser.config.__dict__.copy(),
        "model": bundle.denoiser.state_dict(),
        "ema": None,
        "alphas_cumprod": np.asarray(bundle.schedule.alphas_cumprod).tolist(),
        "stats": {"mean": bundle.mean.tolist(), "std": bundle.std.tolist()},
        "latent_stats": {
            "mean": bundle.latent_mean.tolist(),
            "std": bundle.latent_std.tolist(),
        },
        "skeleton": {
            "names": list(s.names),
            "parents": [int(p) for p in s.parents],
            "offsets": np.asarray(s.offsets).tolist(),
        },
        "sampling_defaults": {"steps": 4, "w_text": 2.0, "w_con": 2.0},
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("--out", default=str(ROOT / "build/bench_model"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--tiny-text",
        action="store_true",
        help="a tiny random text encoder instead of all-MiniLM-L6-v2 (faster export; the text "
        "timings are then not MiniLM's)",
    )
    args = parser.parse_args()
    out = Path(args.out)
    text_dim = TINY_TEXT_DIM if args.tiny_text else 384
    bundle, sizes = build(args.seed, text_dim)
    sizes["text"] = "tiny random BERT" if args.tiny_text else "all-MiniLM-L6-v2"
    torch.set_num_threads(max(1, torch.get_num_threads()))
    export_package(
        bundle,
        out,
        provenance={
            "kind": "random-weight benchmark package (bench/make_model.py)",
            **sizes,
        },
        tiny_text_seed=args.seed if args.tiny_text else None,
    )
    torch.save(checkpoint(bundle), out / "reference.pt")
    (out / "bench_sizes.json").write_text(
        json.dumps(sizes, indent=1) + "\n", encoding="utf-8"
    )
    params = {
        "tokenizer": sum(p.numel() for p in bundle.tokenizer.parameters()),
        "denoiser": sum(p.numel() for p in bundle.denoiser.parameters()),
    }
    print(f"bench model: {out} ({json.dumps(sizes)}; parameters {params})")


if __name__ == "__main__":
    main()
