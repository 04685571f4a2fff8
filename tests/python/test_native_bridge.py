"""The native bridge archive for other engines (scripts/package_native.sh): what it holds,
and that a C program built against nothing but the unpacked archive streams motion."""

from __future__ import annotations

import re
import subprocess
import tarfile
from pathlib import Path

import pytest

TINY = Path("tests/data/tiny_package")
# Every test here packs the built runtime (scripts/test.sh builds it first).
pytestmark = pytest.mark.requires_build


@pytest.fixture(scope="module")
def bridge(repo_root: Path, build: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("dist")
    result = subprocess.run(
        [
            "bash",
            "scripts/package_native.sh",
            "--build",
            str(build),
            "--out",
            str(out),
            "--no-model",
        ],
        cwd=repo_root,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    archive = Path(result.stdout.strip().splitlines()[-1])
    assert re.fullmatch(r"ardy-native-\d+\.\d+\.\d+-linux-\w+\.tar\.gz", archive.name)
    unpacked = tmp_path_factory.mktemp("unpacked")
    with tarfile.open(archive) as tar:
        tar.extractall(unpacked, filter="tar")
    (folder,) = unpacked.iterdir()
    return folder


def test_the_archive_holds_the_header_the_libraries_the_cli_and_the_docs(bridge: Path) -> None:
    for relative in (
        "include/ardy_c.h",
        "lib/libardy_c.so",
        "lib/libonnxruntime.so.1",
        "bin/ardy-generate",
        "examples/minimal.c",
        "README.md",
    ):
        assert (bridge / relative).is_file(), relative
    assert not (bridge / "lib/libonnxruntime.so.1").is_symlink()
    assert not (bridge / "models").exists()  # --no-model


def test_the_library_exports_only_the_c_abi(bridge: Path) -> None:
    symbols = subprocess.run(
        ["nm", "-D", "--defined-only", str(bridge / "lib/libardy_c.so")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    names = symbols[2::3]
    assert len(names) > 40
    assert [n for n in names if not n.startswith("ardy_")] == []


def test_a_c_program_built_against_the_archive_streams_motion(
    bridge: Path, repo_root: Path
) -> None:
    exe = bridge / "bin/minimal"
    subprocess.run(
        [
            "cc",
            "-Wall",
            "-Werror",
            "-I",
            str(bridge / "include"),
            str(bridge / "examples/minimal.c"),
            "-L",
            str(bridge / "lib"),
            "-lardy_c",
            "-Wl,-rpath,$ORIGIN/../lib",
            "-o",
            str(exe),
        ],
        check=True,
    )
    run = subprocess.run(
        [str(exe), str(repo_root / TINY), "a person walks forward"],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    lines = [line for line in run.stdout.splitlines() if line.startswith("t ")]
    assert len(lines) == 7  # every half second from 0 to 3 s
    assert "21 joints at 20 fps" in run.stdout
    assert "worker:" not in run.stderr
    bad = subprocess.run(
        [str(exe), str(repo_root / "no/such/model"), "x"], capture_output=True, text=True
    )
    assert bad.returncode == 1
    assert "cannot load the model" in bad.stderr and "no/such/model" in bad.stderr


def test_the_cli_runs_from_the_archive(bridge: Path, tmp_path: Path, repo_root: Path) -> None:
    timeline = tmp_path / "timeline.json"
    timeline.write_text('{"prompts": [{"time": 0, "text": "a person walks"}]}', encoding="utf-8")
    run = subprocess.run(
        [
            str(bridge / "bin/ardy-generate"),
            "--model",
            str(repo_root / TINY),
            "--timeline",
            str(timeline),
            "--seconds",
            "2",
            "--out-bvh",
            str(tmp_path / "out.bvh"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "out.bvh").read_text(encoding="utf-8").startswith("HIERARCHY")
