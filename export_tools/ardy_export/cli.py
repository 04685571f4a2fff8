"""The ``ardy-export`` command line: one subcommand per tool."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ardy_export import fixtures
from ardy_export.data.cli import add_data_commands
from ardy_export.evaluation.cli import add_eval_commands
from ardy_export.runtime_settings import RUNTIME_SAMPLING_DEFAULTS
from ardy_export.text.cli import add_text_commands
from ardy_export.training.cli import add_training_commands


def _make_fixtures(args: argparse.Namespace) -> int:
    for path in fixtures.write_foundation_fixtures(Path(args.out)):
        print(f"wrote {path} ({path.stat().st_size} bytes)")
    return 0


def _export(args: argparse.Namespace) -> int:
    from ardy_export.package import PackageError, export_package
    from ardy_export.sampling.sampler import ModelBundle

    checkpoint = Path(args.checkpoint)
    if not checkpoint.is_file():
        print(
            f"ardy-export export: no checkpoint at {checkpoint} "
            "(train one with 'ardy-export train denoiser')",
            file=sys.stderr,
        )
        return 1
    bundle = ModelBundle.from_checkpoint(checkpoint)
    try:
        description = export_package(
            bundle,
            args.out,
            provenance={"checkpoint": str(checkpoint), "data": args.data_note},
            text_weights=args.text_weights,
            output_smoothing_frames=args.output_smoothing_frames,
            interpolate_root=args.interpolate_root,
            path_guidance_scale=args.path_guidance_scale,
            text_only_guidance_scale=args.text_only_guidance_scale,
        )
    except PackageError as error:
        print(f"ardy-export export: {error}", file=sys.stderr)
        return 1
    errors = description["provenance"]["parity_max_abs_error"]
    for path in sorted(Path(args.out).iterdir()):
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")
    sampling = description["sampling"]
    print("sampling: " + ", ".join(f"{k} {v}" for k, v in sampling.items()))
    print(
        "ONNX Runtime vs PyTorch, max abs error: "
        + ", ".join(f"{k} {v:.2g}" for k, v in errors.items())
    )
    return 0


def _recover_checkpoint(args: argparse.Namespace) -> int:
    from ardy_export.recover import RecoverError, recover_checkpoint

    package, base = Path(args.package), Path(args.base)
    for path, what in ((package / "model.json", "a model package"), (base, "a checkpoint")):
        if not path.is_file():
            print(f"ardy-export recover-checkpoint: {path} not found ({what})", file=sys.stderr)
            return 1
    try:
        errors = recover_checkpoint(package, base, Path(args.out))
    except RecoverError as error:
        print(f"ardy-export recover-checkpoint: {error}", file=sys.stderr)
        return 1
    print(f"wrote {args.out}")
    print(
        "PyTorch vs the package's graphs, max abs error: "
        + ", ".join(f"{k} {v:.2g}" for k, v in errors.items())
    )
    return 0


def _export_test_package(args: argparse.Namespace) -> int:
    from ardy_export.goldens import write_test_package

    index = write_test_package(args.out, seed=args.seed)
    print(f"wrote the tiny package and {len(index['tensors'])} golden tensors to {args.out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ardy-export",
        description="ARDY for Godot: data, training, evaluation and ONNX export tools.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    make_fixtures = commands.add_parser(
        "make-fixtures",
        help="write the tiny ONNX graphs and golden vectors of the runtime's foundation tests",
        description=(
            "Write mlp.onnx, mlp_golden.json and tokens.onnx (deterministic: regenerating on "
            "one machine gives identical bytes; scripts/make_fixtures.sh regenerates every "
            "fixture)."
        ),
    )
    make_fixtures.add_argument(
        "--out",
        default="tests/data/foundation",
        help="output folder (default: %(default)s, relative to the current directory)",
    )
    make_fixtures.set_defaults(handler=_make_fixtures)

    export = commands.add_parser(
        "export",
        help="export a trained denoiser checkpoint as a model package (model.json + ONNX graphs)",
        description=(
            "Write model.json, history.onnx, denoiser.onnx, decoder.onnx, encoder.onnx, "
            "text_encoder.onnx "
            "and vocab.txt; every graph is checked against PyTorch through ONNX Runtime."
        ),
    )
    export.add_argument(
        "--checkpoint", default="runs/denoiser/final.pt", help="(default: %(default)s)"
    )
    export.add_argument("--out", required=True, help="package folder to write")
    export.add_argument(
        "--data-note",
        default="Bandai Namco Research Motion Dataset 1+2 (CC BY-NC 4.0)",
        help="what the model was trained on, recorded in model.json",
    )
    export.add_argument(
        "--text-weights",
        choices=("float32", "int8"),
        default="int8",
        help="text encoder weights: int8 (24 MB, cosine >= 0.998 to float32) or float32 "
        "(91 MB) (default: %(default)s)",
    )
    unset = "(default: the checkpoint's sampling defaults, else %s)"
    export.add_argument(
        "--output-smoothing-frames",
        type=float,
        help="sigma in frames of the runtime's output filter, 0 for none "
        + unset % RUNTIME_SAMPLING_DEFAULTS["output_smoothing_frames"],
    )
    export.add_argument(
        "--interpolate-root",
        action=argparse.BooleanOptionalAction,
        help="whether the runtime turns sparse root targets into paths "
        + unset % RUNTIME_SAMPLING_DEFAULTS["interpolate_root"],
    )
    export.add_argument(
        "--path-guidance-scale",
        type=float,
        help="multiplier of w_con in windows whose goals are a dense root path alone, "
        "0 < scale <= 1 " + unset % RUNTIME_SAMPLING_DEFAULTS["path_guidance_scale"],
    )
    text_only_scale = (
        "multiplier of w_text in windows with a prompt and no goals, in the first half of the "
        "denoising steps, 0 < scale <= 4 "
    )
    export.add_argument(
        "--text-only-guidance-scale",
        type=float,
        help=text_only_scale + unset % RUNTIME_SAMPLING_DEFAULTS["text_only_guidance_scale"],
    )
    export.set_defaults(handler=_export)

    recover = commands.add_parser(
        "recover-checkpoint",
        help="rebuild a slim denoiser checkpoint from a model package's own graphs",
        description=(
            "Read the denoiser weights out of a package's ONNX graphs (format version 1 or 2) "
            "into a slim checkpoint that 'ardy-export export' takes; the configs, tokenizer "
            "and statistics come from a base checkpoint of the same architecture (e.g. the "
            "one the package was fine-tuned from). Nothing is written unless the rebuilt "
            "model reproduces the package's denoiser, decoder and encoder graphs."
        ),
    )
    recover.add_argument("--package", required=True, help="model package folder")
    recover.add_argument(
        "--base", required=True, help="checkpoint of the same architecture and tokenizer"
    )
    recover.add_argument("--out", required=True, help="checkpoint file to write")
    recover.set_defaults(handler=_recover_checkpoint)

    test_package = commands.add_parser(
        "export-test-package",
        help="write the tiny random-weight package and golden vectors of the C++ parity tests",
    )
    test_package.add_argument(
        "--out", default="tests/data/tiny_package", help="(default: %(default)s)"
    )
    test_package.add_argument("--seed", type=int, default=0, help="(default: %(default)s)")
    test_package.set_defaults(handler=_export_test_package)
    add_text_commands(commands)
    add_data_commands(commands)
    add_training_commands(commands)
    add_eval_commands(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.handler(args))
    except OSError as error:
        print(f"ardy-export {args.command}: {error}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
