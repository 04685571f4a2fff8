"""SConstruct maps Godot's habitual scons targets onto the CMake build."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCONS = Path(sys.executable).parent / "scons"
LIBRARY = ROOT / "demo_project/addons/ardy/bin/libardy.linux.template_debug.x86_64.so"


def run_scons(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(SCONS), "-Q", *arguments],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def test_debug_target_builds_the_extension_through_cmake() -> None:
    result = run_scons("target=template_debug")
    assert result.returncode == 0, result.stdout + result.stderr
    assert LIBRARY.is_file()
    assert (LIBRARY.parent / "libonnxruntime.so.1").is_file()


def test_unknown_target_is_refused_with_a_message() -> None:
    result = run_scons("target=console")
    assert result.returncode == 2
    assert "target must be template_debug or template_release" in result.stdout
