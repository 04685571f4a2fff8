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
    ref = json.loads(Path(sys.argv[2]).read_text(encoding="utf-8")) if len(sys.argv) > 2 else None
    shape = (
        f"C = {cpp['window_tokens']} tokens, H = {cpp['history_tokens']}, "
        f"F = {cpp['future_tokens']}, {cpp['rows']} guidance rows"
    )
    print(f"## ARDY benchmark: {cpp['label']}\n")
    print(
        f"{cpp['cores']} cores; C++: ONNX Runtime {cpp['onnxruntime']}, "
        f"{cpp['threads']} intra-op threads"
        + (" (spinning)" if cpp.get("spinning") else "")
        + (f"; PyTorch {ref['torch']}, {ref['threads']} threads" if ref else "")
        + f". Windows: {shape}, DDIM + guidance + root overwrite + decoding (4 context tokens) + "
        "features + FK.\n"
    )
    print("| measurement | C++ p50 | C++ p99 | PyTorch p50 | PyTorch p99 | PyTorch / C++ (p50) |")
    print("|---|---|---|---|---|---|")
    for key, name in (
        ("window_4_ms", "window, 4 steps"),
        ("window_10_ms", "window, 10 steps"),
        ("denoiser_call_ms", "denoiser call, 3 rows"),
    ):
        row = f"| {name} | {ms(cpp[key])} | {ms(cpp[key], 'p99')} |"
        if ref and key in ref:
            ratio = ref[key]["p50"] / cpp[key]["p50"]
            row += f" {ms(ref[key])} | {ms(ref[key], 'p99')} | {ratio:.2f}x |"
        else:
            row += " - | - | - |"
        print(row)
    print()
    rows: list[tuple[str, str, str]] = [
        (
            "window preparation (history, goals, cached text)",
            ms(cpp["prepare_ms"]),
            ms(cpp["prepare_ms"], "p99"),
        ),
        ("decoder call", ms(cpp["decoder_call_ms"]), ms(cpp["decoder_call_ms"], "p99")),
        (
            f"text encoding, cold ({cpp['text_model']})",
            f"{cpp['text_cold_us']['p50'] / 1e3:.2f} ms",
            f"{cpp['text_cold_us']['p99'] / 1e3:.2f} ms",
        ),
        ("text encoding, cached", us(cpp["text_cached_us"]), us(cpp["text_cached_us"], "p99")),
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
                f"batch of {n} windows (characters), 4 steps, one call: per window",
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
        ("planner frame (advance + sample)", us(cpp["frame_us"]), us(cpp["frame_us"], "p99"))
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
    p = cpp["planner"]
    print(
        f"Memory (C++ process): RSS {cpp['rss_loaded_mb']:.0f} MB with the package loaded, peak "
        f"{cpp['rss_peak_mb']:.0f} MB. Planner run ({p['windows']} windows, "
        f"{p['splices']} splices, {p['late']} late): last window latency "
        f"{p['latency_ms']:.1f} ms, replan buffer "
        f"{p['buffer_frames']} frames, underrun {p['underrun_s']:.3f} s"
        + (f"; CPU used while it streamed: {p['cpu_cores']:.2f} cores." if "cpu_cores" in p else ".")
    )


if __name__ == "__main__":
    main()
