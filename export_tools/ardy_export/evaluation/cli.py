"""The ``ardy-export eval ...`` subcommands (registered by ``ardy_export.cli``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "configs" / "evaluation.yaml"


def _run(args: argparse.Namespace) -> int:
    from ardy_export.evaluation.report import write_report
    from ardy_export.evaluation.run import SECTIONS, evaluate
    from ardy_export.training.common import load_config

    config = load_config(args.config)
    for key in ("model", "out", "cli"):
        if getattr(args, key) is not None:
            config[key] = getattr(args, key)
    sections = args.sections.split(",") if args.sections else None
    unknown = [s for s in sections or [] if s not in SECTIONS]
    if unknown:
        print(
            f"ardy-export eval run: unknown sections {unknown}; known: {list(SECTIONS)}",
            file=sys.stderr,
        )
        return 2
    for key, hint in (
        ("model", "ardy-export export"),
        ("evaluator", "ardy-export eval train-evaluator"),
        ("data", "ardy-export data prepare"),
        ("bank", "ardy-export text bank"),
    ):
        if not Path(config[key]).exists():
            print(
                f"ardy-export eval run: {key} {config[key]} does not exist (make it with '{hint}')",
                file=sys.stderr,
            )
            return 1
    results = evaluate(config, sections)
    report = write_report(results, Path(config["out"]))
    print(f"wrote {report}")
    return 0


def _report(args: argparse.Namespace) -> int:
    import json

    from ardy_export.evaluation.report import write_report

    out = Path(args.out)
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    print(f"wrote {write_report(results, out)}")
    return 0


def _ablations(args: argparse.Namespace) -> int:
    from ardy_export.evaluation.report import write_ablation_table

    print(f"wrote {write_ablation_table(Path(args.runs), Path(args.out))}")
    return 0


def _tokenizer(args: argparse.Namespace) -> int:
    import json

    import numpy as np

    from ardy_export.evaluation.roundtrip import evaluate_tokenizer
    from ardy_export.training.denoiser_train import tokenizer_from_checkpoint

    try:
        tokenizer, ckpt = tokenizer_from_checkpoint(Path(args.checkpoint))
        mean = np.asarray(ckpt["stats"]["mean"], np.float64)
        std = np.asarray(ckpt["stats"]["std"], np.float64)
        result = evaluate_tokenizer(tokenizer, mean, std, args.data, args.split)
    except (FileNotFoundError, ValueError) as error:
        print(f"ardy-export eval tokenizer: {error}", file=sys.stderr)
        return 1
    text = json.dumps(result, indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0


def add_eval_commands(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add the ``eval`` command group to the top-level subparsers."""
    from ardy_export.evaluation.retrieval import add_commands

    group = commands.add_parser(
        "eval",
        help="evaluate a model package in the paper's terms (retrieval evaluator, report)",
        description="Train the retrieval evaluator, run a package through the C++ CLI on the "
        "held-out test groups, and write the Markdown report with its plots.",
    )
    sub = group.add_subparsers(dest="eval_command", required=True, metavar="EVAL_COMMAND")
    add_commands(sub)
    p = sub.add_parser("run", help="generate with the C++ CLI, measure, write the report")
    p.add_argument("--config", default=str(DEFAULT_CONFIG), help="(default: %(default)s)")
    p.add_argument("--model", help="package folder (overrides the config)")
    p.add_argument("--out", help="report folder (overrides the config)")
    p.add_argument("--cli", help="ardy-generate binary (default: the newest local build)")
    p.add_argument(
        "--sections",
        help="comma-separated subset (default: all); results of "
        "other sections already in OUT/results.json are kept",
    )
    p.set_defaults(handler=_run)
    p = sub.add_parser("report", help="rewrite the report from OUT/results.json")
    p.add_argument("--out", default="docs/evaluation", help="(default: %(default)s)")
    p.set_defaults(handler=_report)
    p = sub.add_parser(
        "tokenizer",
        help="encode and decode the test clips: skate, seam jerk, contacts, joint error",
    )
    p.add_argument("--checkpoint", required=True, help="tokenizer or denoiser checkpoint")
    p.add_argument("--data", default="data/processed", help="(default: %(default)s)")
    p.add_argument("--split", default="test", choices=("train", "test"))
    p.add_argument("--out", help="also write the figures to this JSON file")
    p.set_defaults(handler=_tokenizer)
    p = sub.add_parser("ablations", help="the ablation table from scripts/run_ablations.sh")
    p.add_argument("--runs", default="runs/ablations", help="(default: %(default)s)")
    p.add_argument("--out", default="docs/evaluation/ablations.md", help="(default: %(default)s)")
    p.set_defaults(handler=_ablations)
