"""Markdown tables from ardy-bench's JSON (C++) and bench/reference.py's JSON (PyTorch).

python bench/report.py CPP_JSON [TORCH_JSON]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def ms(s: dict, key: str = "p50") -> str:
    return f"{s[key]:.2f} ms"


def us(s: dict, key: str = "p50") -> str:
    return f"{s[key]:.2f} us"


def main() -> None:
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    cpp = json.loads(Path(sys.argv[1]).read_text(encoding="utf-8"))
    ref = (
        json.loads(Path(sys.argv[2]).read_text(encoding="utf-8"))
        if len(sys.argv) > 2
        else None
    )
    print(f"## ARDY benchmark: {cpp['label']}\n")
    peak = cpp.get("peak_gflops", 0.0)
    den = cpp["denoiser"]
    print(
        f"{cpp['cores']} cores; C++: ONNX Runtime {cpp['onnxruntime']}, "
        f"{cpp['threads']} intra-op thread{'' if cpp['threads'] == 1 else 's'}"
        + (" (spinning)" if cpp.get("spinning") else "")
        + (f"; PyTorch {ref['torch']}, {ref['threads']} threads" if ref else "")
        + f". Denoiser {den['stages']} x {den['layers']} layers, width {den['width']}; windows of "
        f"C = {cpp['window_tokens']} tokens: DDIM + guidance + root overwrite + decoding "
        "(4 context tokens) + features + FK."
        + (
            f" Peak: a {cpp['probe_size']}-square MatMul in ONNX Runtime reaches {peak:.1f} "
            "GFLOP/s on every core."
            if peak
            else ""
        )
        + " GFLOP: the matrix products of the DDIM part (history and goals graphs once, then "
        "every step's denoiser calls); uncached: what format version 1's one call per step "
        "with every row recomputing the history, the goals and the future tokens would do.\n"
    )
    print(
        "| window, 4 steps | rows | H | F (with goals) | C++ p50 | C++ p99 | DDIM p50 | GFLOP | "
        "GFLOP/s | of peak | uncached GFLOP | PyTorch p50 | PyTorch / C++ (p50) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    order = ("text", "waypoints", "full")
    for key, case in sorted(
        cpp["cases"].items(), key=lambda item: order.index(item[0])
    ):
        gflop = case["flops"] / 1e9
        rate = gflop / (case["ddim_4_ms"]["p50"] / 1e3)
        of_peak = f"{100 * rate / peak:.0f} %" if peak else "-"
        row = (
            f"| {case['name']} | {case['rows']} | {case['history_tokens']} | "
            f"{case['future_tokens']} ({case['future_attended']}) | {ms(case['window_4_ms'])} | "
            f"{ms(case['window_4_ms'], 'p99')} | {ms(case['ddim_4_ms'])} | {gflop:.3f} | "
            f"{rate:.1f} | {of_peak} | {case['uncached_flops'] / 1e9:.3f} |"
        )
        reference = ref["cases"].get(key) if ref else None
        if reference:
            ratio = reference["window_4_ms"]["p50"] / case["window_4_ms"]["p50"]
            row += f" {ms(reference['window_4_ms'])} | {ratio:.2f}x |"
        else:
            row += " - | - |"
        print(row)
    print()
    print("| measurement | C++ p50 | C++ p99 | PyTorch p50 | PyTorch / C++ (p50) |")
    print("|---|---|---|---|---|")
    row = f"| full window, 10 steps | {ms(cpp['window_10_ms'])} | {ms(cpp['window_10_ms'], 'p99')} |"
    if ref:
        ratio = ref["window_10_ms"]["p50"] / cpp["window_10_ms"]["p50"]
        row += f" {ms(ref['window_10_ms'])} | {ratio:.2f}x |"
    else:
        row += " - | - |"
    print(row)
    if ref:
        print(
            f"| PyTorch: one uncached denoiser call, the full case's 3 rows | - | - | "
            f"{ms(ref['denoiser_call_ms'])} | - |"
        )
    print()
    rows: list[tuple[str, str, str]] = [
        (
            "window preparation (history, goals, cached text)",
            ms(cpp["prepare_ms"]),
            ms(cpp["prepare_ms"], "p99"),
        ),
        ("history call", ms(cpp["history_call_ms"]), ms(cpp["history_call_ms"], "p99")),
        ("goals call", ms(cpp["goals_call_ms"]), ms(cpp["goals_call_ms"], "p99")),
        (
            "denoiser call, the full case's constraint row",
            ms(cpp["denoiser_call_ms"]),
            ms(cpp["denoiser_call_ms"], "p99"),
        ),
        ("decoder call", ms(cpp["decoder_call_ms"]), ms(cpp["decoder_call_ms"], "p99")),
        (
            f"text encoding, cold ({cpp['text_model']})",
            f"{cpp['text_cold_us']['p50'] / 1e3:.2f} ms",
            f"{cpp['text_cold_us']['p99'] / 1e3:.2f} ms",
        ),
        (
            "text encoding, cached",
            us(cpp["text_cached_us"]),
            us(cpp["text_cached_us"], "p99"),
        ),
        (
            "planner advance(), caller's thread, 60 Hz",
            us(cpp["advance_us"]),
            us(cpp["advance_us"], "p99"),
        ),
        (
            "planner sample_current(), caller's thread, 60 Hz",
            us(cpp["sample_us"]),
            us(cpp["sample_us"], "p99"),
        ),
    ]
    for size, batch in cpp.get("batch_window_4_ms", {}).items():
        if size == "1":
            continue
        n = int(size)
        rows.append(
            (
                f"batch of {n} full windows (characters), 4 steps, one call: per window",
                f"{batch['p50'] / n:.2f} ms",
                f"{batch['p99'] / n:.2f} ms",
            )
        )
    if "sample_hot_us" in cpp:
        rows.append(
            (
                "planner sample(), hot loop",
                us(cpp["sample_hot_us"]),
                us(cpp["sample_hot_us"], "p99"),
            )
        )
    rows.append(
        (
            "planner frame (advance + sample)",
            us(cpp["frame_us"]),
            us(cpp["frame_us"], "p99"),
        )
    )
    rows.append(
        (
            "planner command (set_prompt / add_waypoint)",
            us(cpp["command_us"]),
            us(cpp["command_us"], "p99"),
        )
    )
    print("| C++ only | p50 | p99 |")
    print("|---|---|---|")
    for name, p50, p99 in rows:
        print(f"| {name} | {p50} | {p99} |")
    print()
    if cpp.get("crowds"):
        print(
            "| crowd, one WindowBatcher, real time at 60 Hz | seconds | windows | late | "
            "underrun, sum / worst planner | largest batch | CPU cores | caller's thread per "
            "frame, p50 / p99 |"
        )
        print("|---|---|---|---|---|---|---|---|")
        for crowd in cpp["crowds"]:
            print(
                f"| {crowd['planners']} planners | {crowd['seconds']:.1f} | {crowd['windows']} | "
                f"{crowd['late']} | {crowd['underrun_total_s']:.3f} s / "
                f"{crowd['underrun_max_s']:.3f} s | {crowd['largest_batch']} | "
                f"{crowd['cpu_cores']:.2f} | {crowd['frame_us']['p50']:.1f} / "
                f"{crowd['frame_us']['p99']:.1f} us |"
            )
        print()
    p = cpp["planner"]
    print(
        f"Memory (C++ process): RSS {cpp['rss_loaded_mb']:.0f} MB with the package loaded, peak "
        f"{cpp['rss_peak_mb']:.0f} MB. Planner run ({p['windows']} windows, "
        f"{p['splices']} splices, {p['late']} late): last window latency "
        f"{p['latency_ms']:.1f} ms, replan buffer "
        f"{p['buffer_frames']} frames, underrun {p['underrun_s']:.3f} s"
        + (
            f"; CPU used while it streamed: {p['cpu_cores']:.2f} cores."
            if "cpu_cores" in p
            else "."
        )
    )


if __name__ == "__main__":
    main()
