"""Shared pytest fixtures: where the repository and its committed test data are."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT


@pytest.fixture(scope="session")
def foundation_dir(repo_root: Path) -> Path:
    return repo_root / "tests" / "data" / "foundation"
