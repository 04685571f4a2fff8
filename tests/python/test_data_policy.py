"""The one policy for tests that need the Bandai Namco data (conftest.py), run on planted
tests in a child pytest: a loud skip without the data, a failure with ARDY_REQUIRE_DATA=1,
a failure for a test that reaches for the data without its marker."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
PLANTED = """
import pytest
from conftest import require


@pytest.mark.requires_data
def test_marked() -> None:
    require("requires_data")


def test_unmarked_reaching_for_the_data() -> None:
    require("requires_data")


def test_needing_nothing() -> None:
    assert True
"""


def _run(tmp_path: Path, **environment: str) -> subprocess.CompletedProcess[str]:
    (tmp_path / "test_planted.py").write_text(PLANTED, encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if not k.startswith("ARDY_REQUIRE")}
    env["PYTHONPATH"] = os.pathsep.join([str(HERE), env.get("PYTHONPATH", "")])
    env.update(environment)
    command = [sys.executable, "-m", "pytest", "-p", "conftest", "-p", "no:cacheprovider"]
    return subprocess.run(
        [*command, "-q", "-rfEs", "--rootdir", str(tmp_path), str(tmp_path / "test_planted.py")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )


def test_without_the_data_a_marked_test_skips_with_the_reason(tmp_path: Path) -> None:
    result = _run(tmp_path, ARDY_BANDAI_DIR=str(tmp_path / "nowhere"))
    out = result.stdout
    assert f"Bandai Namco data not found at {tmp_path / 'nowhere'}" in out, out
    assert "set ARDY_BANDAI_DIR" in out
    assert "without @pytest.mark.requires_data" in out  # the unmarked one fails
    assert out.rstrip().splitlines()[-1].startswith("1 failed, 1 passed, 1 skipped"), out


def test_with_ardy_require_data_the_skip_is_a_failure_naming_the_data(tmp_path: Path) -> None:
    result = _run(tmp_path, ARDY_BANDAI_DIR=str(tmp_path / "nowhere"), ARDY_REQUIRE_DATA="1")
    out = result.stdout
    assert result.returncode != 0
    assert "ARDY_REQUIRE_DATA=1: required here" in out and "Bandai Namco data not found" in out
    assert "skipped" not in out.rstrip().splitlines()[-1], out


def test_with_the_data_the_marked_test_runs(tmp_path: Path) -> None:
    data = tmp_path / "bandai"
    data.mkdir()
    for name in ("dataset-1.tar.xz", "dataset-2.tar.xz"):
        (data / name).write_bytes(b"")
    result = _run(tmp_path, ARDY_BANDAI_DIR=str(data), ARDY_REQUIRE_DATA="1")
    assert result.stdout.rstrip().splitlines()[-1].startswith("3 passed"), result.stdout
