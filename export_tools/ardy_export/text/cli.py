"""The ``ardy-export text ...`` subcommands (registered by ``ardy_export.cli``)."""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path
from typing import Any

from ardy_export.text import sentences as text_sentences

DEFAULT_CACHE = "runs/text/embeddings.npz"
DEFAULT_CASES = "tests/data/text/wordpiece_cases.json"


def _sentences(args: argparse.Namespace) -> int:
    if args.canonical:
        print(text_sentences.canonical_prompt(args.content, args.style))
        return 0
    sentences = text_sentences.sentences_for(args.dataset, args.content, args.style, args.count)
    for sentence in sentences:
        print(sentence)
    return 0


def _stats(args: argparse.Namespace) -> int:
    groups = text_sentences.all_sentences(args.dataset)
    counts = [len(v) for v in groups.values()]
    unique = {s for v in groups.values() for s in v}
    longest = max(unique, key=lambda s: (len(s), s))
    report: dict[str, Any] = {
        "labels": len(groups),
        "sentences_per_label": {
            "min": min(counts),
            "median": statistics.median(counts),
            "max": max(counts),
        },
        "sentences": sum(counts),
        "distinct_sentences": len(unique),
        "longest_sentence_chars": longest,
        "grammar_sha256": text_sentences.grammar_digest(),
    }
    if args.tokens:
        from ardy_export.text.export import longest_sentence_tokens

        tokens, sentence = longest_sentence_tokens()
        report["longest_sentence_tokens"] = {"tokens": tokens, "sentence": sentence}
    print(json.dumps(report, indent=1))
    return 0


def _embed(args: argparse.Namespace) -> int:
    from ardy_export.text.encoder import TextEncoder, embed_all_labels

    encoder = TextEncoder(max_tokens=args.max_tokens, batch_size=args.batch_size)
    labels = text_sentences.labels(args.dataset)
    meta = embed_all_labels(args.out, encoder, labels, progress=not args.quiet)
    print(json.dumps(meta, indent=1))
    print(f"wrote {args.out}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from ardy_export.text.export import export_text_encoder

    settings = export_text_encoder(
        args.out,
        max_tokens=args.max_tokens,
        opset=args.opset,
        tiny_random_seed=args.tiny_seed,
        weights=args.weights,
    )
    text = json.dumps(settings, indent=1)
    if args.settings:
        Path(args.settings).write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0


def _cases(args: argparse.Namespace) -> int:
    from ardy_export.text.export import write_wordpiece_cases

    path = write_wordpiece_cases(args.out, max_tokens=args.max_tokens)
    print(f"wrote {path} ({path.stat().st_size} bytes)")
    return 0


def _bank(args: argparse.Namespace) -> int:
    from ardy_export.text.encoder import write_label_bank

    meta = write_label_bank(args.out, args.sentences)
    size = Path(args.out).stat().st_size / 1e6
    print(f"wrote {args.out}: {meta['sentences_per_label']} sentences per label, {size:.1f} MB")
    return 0


def add_text_commands(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add the ``text`` command group to the top-level subparsers."""
    from ardy_export.text.encoder import MAX_TOKENS
    from ardy_export.text.export import OPSET, WEIGHT_FORMATS

    text = commands.add_parser(
        "text",
        help="label sentences, text embeddings and the text encoder's ONNX export",
        description="Sentences from motion labels, their MiniLM embeddings, and text_encoder.onnx.",
    )
    sub = text.add_subparsers(dest="text_command", required=True, metavar="TEXT_COMMAND")

    p = sub.add_parser("sentences", help="print the sentences of one label")
    p.add_argument("--dataset", default="dataset-2", help="dataset-1 or dataset-2 (%(default)s)")
    p.add_argument("--content", required=True, help="e.g. walk-turn-left")
    p.add_argument("--style", required=True, help="e.g. elderly")
    p.add_argument("--count", type=int, default=None, help="print only the first COUNT")
    p.add_argument("--canonical", action="store_true", help="print the canonical prompt only")
    p.set_defaults(handler=_sentences)

    p = sub.add_parser("stats", help="sentence counts per label and the longest sentence")
    p.add_argument("--dataset", default=None, help="one dataset (default: both)")
    p.add_argument("--tokens", action="store_true", help="also count word pieces (loads MiniLM)")
    p.set_defaults(handler=_stats)

    p = sub.add_parser(
        "embed",
        help="embed every sentence of every label into an npz cache for training",
        description="Runs all-MiniLM-L6-v2 once over every distinct sentence (about a minute "
        "on 2 CPU cores) and writes sentences, embeddings and the label index.",
    )
    p.add_argument("--out", default=DEFAULT_CACHE, help="npz path (default: %(default)s)")
    p.add_argument("--dataset", default=None, help="one dataset (default: both)")
    p.add_argument("--max-tokens", type=int, default=MAX_TOKENS, help="(default: %(default)s)")
    p.add_argument("--batch-size", type=int, default=128, help="(default: %(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(handler=_embed)

    p = sub.add_parser(
        "bank",
        help="a small float16 bank of label embeddings (training machines without MiniLM)",
    )
    p.add_argument("--out", default="runs/text/bank.npz", help="npz path (default: %(default)s)")
    p.add_argument("--sentences", type=int, default=16, help="per label (default: %(default)s)")
    p.set_defaults(handler=_bank)

    p = sub.add_parser(
        "export",
        help="write text_encoder.onnx and vocab.txt; print the text settings for model.json",
    )
    p.add_argument("--out", required=True, help="output folder (the model package)")
    p.add_argument("--max-tokens", type=int, default=MAX_TOKENS, help="(default: %(default)s)")
    p.add_argument("--opset", type=int, default=OPSET, help="(default: %(default)s)")
    p.add_argument(
        "--weights", choices=WEIGHT_FORMATS, default="float32", help="(default: %(default)s)"
    )
    p.add_argument(
        "--tiny-seed",
        type=int,
        default=None,
        help="export a tiny random-weight encoder with this seed (for test packages)",
    )
    p.add_argument("--settings", default=None, help="also write the settings JSON to this file")
    p.set_defaults(handler=_export)

    p = sub.add_parser(
        "wordpiece-cases", help="write the tokenizer parity cases for the C++ runtime"
    )
    p.add_argument("--out", default=DEFAULT_CASES, help="(default: %(default)s)")
    p.add_argument("--max-tokens", type=int, default=MAX_TOKENS, help="(default: %(default)s)")
    p.set_defaults(handler=_cases)
