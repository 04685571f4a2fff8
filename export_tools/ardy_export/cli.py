"""The ``ardy-export`` command line: one subcommand per tool."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ardy_export import fixtures
from ardy_export.data.cli import add_data_commands
from ardy_export.text.cli import add_text_commands
from ardy_export.training.cli import add_training_commands


def _make_fixtures(args: argparse.Namespace) -> int:
    for path in fixtures.write_foundation_fixtures(Path(args.out)):
        print(f"wrote {path} ({path.stat().st_size} bytes)")
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
            "Write mlp.onnx, mlp_golden.json and tokens.onnx (deterministic: regenerating "
            "gives identical bytes)."
        ),
    )
    make_fixtures.add_argument(
        "--out",
        default="tests/data/foundation",
        help="output folder (default: %(default)s, relative to the current directory)",
    )
    make_fixtures.set_defaults(handler=_make_fixtures)
    add_text_commands(commands)
    add_data_commands(commands)
    add_training_commands(commands)
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
