"""``ardy-export data ...``: prepare the dataset, make the split, statistics, reports."""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Any

from ardy_export.data.compact import pack_compact, unpack_compact
from ardy_export.data.config import DataConfig, load_data_config


def _config(args: argparse.Namespace) -> DataConfig:
    return load_data_config(args.config) if args.config else load_data_config()


def _print_summary(summary: dict[str, Any]) -> None:
    print(f"clips: {summary['clips']} ({summary['frames']} frames at 20 fps, {summary['hours']} h)")
    for dataset, d in summary["per_dataset"].items():
        print(
            f"  {dataset}: {d['clips']} clips, {d['frames']} frames, "
            f"{d['test_clips']} in the test split"
        )
    if summary["skipped_without_motion"]:
        print(f"skipped (label file without motion): {summary['skipped_without_motion']}")
    if summary["failed"]:
        print(f"failed: {len(summary['failed'])} (see the warnings above)")
    thresholds = summary["contact_thresholds"]
    print(
        f"contact thresholds (Foot_L, Toes_L, Foot_R, Toes_R): height {thresholds['height_m']} m,"
        f" speed {thresholds['speed_m_per_s']} m/s; contact ratio {summary['contact_ratio']}"
    )
    print(
        f"dataset foot skate: {summary['skate_contact_labels_m_per_s']} m/s over labelled "
        f"contacts; {summary['skate_height_based_m_per_s']} m/s by height "
        f"{summary['skate_height_m']} m (the paper's metric)"
    )
    if "seconds_taken" in summary:
        print(f"built in {summary['seconds_taken']} s; {summary['bytes'] / 1e6:.1f} MB")


def _prepare(args: argparse.Namespace) -> int:
    from ardy_export.data.dataset import prepare

    config = _config(args)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            summary = prepare(
                source=Path(args.source or config.source),
                out=Path(args.out or config.out),
                raw=Path(args.raw or config.raw),
                config=config,
                workers=args.workers,
                force=args.force,
            )
    except (FileNotFoundError, ValueError) as error:
        print(f"ardy-export data prepare: {error}", file=sys.stderr)
        return 1
    finally:
        for warning in caught:
            print(f"warning: {warning.message}", file=sys.stderr)
    _print_summary(summary)
    return 0


def _make_split(args: argparse.Namespace) -> int:
    from ardy_export.data.dataset import group_frames, load_index
    from ardy_export.data.split import (
        SPLIT_PATH,
        check_split,
        group_sentences,
        make_split,
        save_split,
    )

    config = _config(args)
    processed = Path(args.processed or config.out)
    try:
        index = load_index(processed)["clips"]
    except FileNotFoundError as error:
        print(f"ardy-export data make-split: {error}", file=sys.stderr)
        return 1
    frames = group_frames(index)
    sentences = group_sentences(frames)
    held_out = make_split(
        frames,
        config.split_seed,
        config.split_test_fraction,
        config.split_min_train_groups,
        sentences,
    )
    problems = check_split(frames, set(held_out), sentences)
    for problem in problems:
        print(f"warning: {problem}", file=sys.stderr)
    out = Path(args.out) if args.out else SPLIT_PATH
    if args.check:
        tmp = out.with_suffix(".check.tmp")
        save_split(
            held_out,
            tmp,
            seed=config.split_seed,
            test_fraction=config.split_test_fraction,
            min_train_groups=config.split_min_train_groups,
        )
        same = out.is_file() and tmp.read_bytes() == out.read_bytes()
        tmp.unlink()
        print(f"{out}: {'matches' if same else 'DIFFERS from'} the regenerated split")
        return 0 if same else 1
    save_split(
        held_out,
        out,
        seed=config.split_seed,
        test_fraction=config.split_test_fraction,
        min_train_groups=config.split_min_train_groups,
    )
    test_frames = sum(frames[g] for g in held_out)
    print(
        f"wrote {out}: {len(held_out)} of {len(frames)} groups held out "
        f"({test_frames} of {sum(frames.values())} frames)"
    )
    if (processed / "index.json").is_file():
        from ardy_export.data.dataset import refresh_split

        refresh_split(processed, out, config)
        print(f"updated the split column of {processed / 'index.json'}")
    return 0


def _stats(args: argparse.Namespace) -> int:
    from ardy_export.data.dataset import load_clips
    from ardy_export.data.normalization import compute_normalization_stats

    config = _config(args)
    processed = Path(args.processed or config.out)
    try:
        clips = load_clips(processed, split="train")
    except FileNotFoundError as error:
        print(f"ardy-export data stats: {error}", file=sys.stderr)
        return 1
    stats = compute_normalization_stats(
        clips,
        seed=config.norm_seed,
        window_stride=config.norm_window_stride,
        history_frames=config.norm_history_frames,
        future_frames=config.norm_future_frames,
        std_floor=config.norm_std_floor,
    )
    out = Path(args.out) if args.out else processed / "normalization.npz"
    stats.save(out)
    print(f"wrote {out}: {json.dumps(stats.info)}")
    return 0


def _stitch_report(args: argparse.Namespace) -> int:
    import numpy as np

    from ardy_export.data.augment import mirror_clip
    from ardy_export.data.dataset import load_clips
    from ardy_export.data.stitching import build_stitched_sequences, stitch_quality

    config = _config(args)
    processed = Path(args.processed or config.out)
    try:
        clips = load_clips(processed, split="train")
    except FileNotFoundError as error:
        print(f"ardy-export data stitch-report: {error}", file=sys.stderr)
        return 1
    clips = clips + [mirror_clip(c) for c in clips]
    rng = np.random.default_rng(args.seed)
    sequences = build_stitched_sequences(clips, rng, args.count, args.max_seconds)
    quality = stitch_quality(sequences, clips, rng)
    frames = sum(s.frames for s in sequences)
    print(f"{len(sequences)} sequences, {frames} frames, {quality['joins']} joins")
    for key, value in quality.items():
        print(f"  {key}: {value}")
    return 0


def _export_bvh(args: argparse.Namespace) -> int:
    from ardy_export.data.augment import mirror_features
    from ardy_export.data.dataset import load_clips
    from ardy_export.data.features import write_features_bvh

    config = _config(args)
    processed = Path(args.processed or config.out)
    try:
        clips = {c.name: c for c in load_clips(processed)}
    except FileNotFoundError as error:
        print(f"ardy-export data export-bvh: {error}", file=sys.stderr)
        return 1
    unknown = [name for name in args.clips if name not in clips]
    if unknown:
        print(
            f"ardy-export data export-bvh: unknown clip(s) {unknown} (names as in "
            f"{processed / 'index.json'}, e.g. dataset-2_walk_normal_001)",
            file=sys.stderr,
        )
        return 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in args.clips:
        features = clips[name].features
        if args.mirror:
            features, name = mirror_features(features), name + "_mirror"
        path = out / f"{name}.bvh"
        write_features_bvh(path, features, config.fps)
        print(f"wrote {path}")
    return 0


def _pack_compact(args: argparse.Namespace) -> int:
    config = load_data_config(args.config)
    processed = Path(args.processed or config.out)
    try:
        sizes = pack_compact(processed, args.out, args.split)
    except FileNotFoundError as error:
        print(f"ardy-export data pack-compact: {error} (run 'data prepare' first)", file=sys.stderr)
        return 1
    print(
        f"wrote {args.out}: {sizes['compact_bytes'] / 1e6:.1f} MB "
        f"(clips.npz is {sizes['clips_npz_bytes'] / 1e6:.1f} MB)"
    )
    return 0


def _unpack_compact(args: argparse.Namespace) -> int:
    try:
        frames = unpack_compact(args.compact, args.out)
    except FileNotFoundError as error:
        print(f"ardy-export data unpack-compact: {error}", file=sys.stderr)
        return 1
    print(f"rebuilt {frames} frames into {args.out}")
    return 0


def add_data_commands(commands: argparse._SubParsersAction) -> None:
    """Register the ``data`` command group on the top-level subparsers."""
    data = commands.add_parser(
        "data",
        help="prepare the BVH dataset, the train/test split, statistics and reports",
        description="Data pipeline commands (settings: export_tools/configs/data.yaml).",
    )
    sub = data.add_subparsers(dest="data_command", required=True, metavar="DATA_COMMAND")

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--config", help="data config YAML (default: export_tools/configs/data.yaml)"
        )

    prepare = sub.add_parser(
        "prepare",
        help="unpack the archives and convert every clip to features",
        description=(
            "Unpack dataset-*.tar.xz into RAW, convert every clip (30 -> 20 fps, model skeleton,"
            " 258 features, contacts) and write clips.npz, index.json, labels.json and "
            "skeleton.json to OUT. Does nothing when OUT is up to date."
        ),
    )
    common(prepare)
    prepare.add_argument("--source", help="folder with the archives (default: config source)")
    prepare.add_argument("--out", help="output folder (default: config out)")
    prepare.add_argument("--raw", help="unpack folder (default: config raw)")
    prepare.add_argument("--workers", type=int, help="processes (default: config workers)")
    prepare.add_argument("--force", action="store_true", help="rebuild even if up to date")
    prepare.set_defaults(handler=_prepare)

    split = sub.add_parser(
        "make-split",
        help="regenerate split.json (held-out content/style groups) from the prepared index",
        description="Deterministic: the same data and config give a byte-identical file.",
    )
    common(split)
    split.add_argument("--processed", help="prepared dataset folder (default: config out)")
    split.add_argument("--out", help="split file (default: the package's data/split.json)")
    split.add_argument(
        "--check",
        action="store_true",
        help="only compare the regenerated split with the file; exit 1 if they differ",
    )
    split.set_defaults(handler=_make_split)

    stats = sub.add_parser(
        "stats",
        help="normalization statistics over the training split",
        description="Write mean/std per feature (normalization.py) to an .npz.",
    )
    common(stats)
    stats.add_argument("--processed", help="prepared dataset folder (default: config out)")
    stats.add_argument("--out", help="output .npz (default: PROCESSED/normalization.npz)")
    stats.set_defaults(handler=_stats)

    export = sub.add_parser(
        "export-bvh",
        help="write processed clips back to BVH (model skeleton, T-pose rest) for viewing",
    )
    common(export)
    export.add_argument("clips", nargs="+", help="clip names, e.g. dataset-2_walk_normal_001")
    export.add_argument("--processed", help="prepared dataset folder (default: config out)")
    export.add_argument("--out", default="data/bvh", help="output folder (default: %(default)s)")
    export.add_argument("--mirror", action="store_true", help="write the mirrored clips")
    export.set_defaults(handler=_export_bvh)

    report = sub.add_parser(
        "stitch-report",
        help="build stitched sequences from the training split and print their quality",
    )
    common(report)
    report.add_argument("--processed", help="prepared dataset folder (default: config out)")
    report.add_argument("--count", type=int, default=100, help="sequences (default: %(default)s)")
    report.add_argument(
        "--max-seconds", type=float, default=20.0, help="longest sequence (default: %(default)s)"
    )
    report.add_argument("--seed", type=int, default=0, help="random seed (default: %(default)s)")
    report.set_defaults(handler=_stitch_report)

    pack = sub.add_parser(
        "pack-compact",
        help="a compact copy of the prepared dataset (about a sixth) to move to a training machine",
    )
    common(pack)
    pack.add_argument("--processed", help="prepared dataset folder (default: config out)")
    pack.add_argument("--out", default="data/compact", help="output folder (default: %(default)s)")
    pack.add_argument("--split", choices=("train", "test"), help="keep only this split's clips")
    pack.set_defaults(handler=_pack_compact)

    unpack = sub.add_parser(
        "unpack-compact", help="rebuild a prepared dataset (clips.npz, index) from a compact copy"
    )
    unpack.add_argument("compact", help="folder written by pack-compact")
    unpack.add_argument(
        "--out", default="data/processed", help="output folder (default: %(default)s)"
    )
    unpack.set_defaults(handler=_unpack_compact)
