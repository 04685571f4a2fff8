"""Shared pytest fixtures: where the repository, its committed test data, the Bandai Namco
data and the build are, and the one policy for tests that need what a checkout lacks.

Markers (the only way a test may depend on these):

- ``requires_data``: the Bandai Namco archives (``dataset-1.tar.xz``, ``dataset-2.tar.xz``)
  in ``$ARDY_BANDAI_DIR``, by default ``../shared/data/bandai`` beside the checkout.
- ``requires_prepared_data``: the prepared dataset (``data/processed``, made by
  ``ardy-export data prepare``).
- ``requires_build``: the built runtime (``build/template_debug``, made by scripts/build.sh).

Without what it needs, a marked test is skipped with one loud reason. ``ARDY_REQUIRE_DATA=1``
(set by .ci/run) turns a missing-data skip into a failure, and ``ARDY_REQUIRE_BUILD=1`` (set
by scripts/test.sh, which builds first) a missing-build skip, so that neither can pass
without running those tests. A test that reaches for the data through these helpers
without its marker fails.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

# No telemetry from ONNX Runtime in the tests, even those that import it before
# ardy_export (which sets the same; see its __init__).
os.environ.setdefault("ORT_DISABLE_TELEMETRY", "1")

REPO_ROOT = Path(__file__).resolve().parents[2]
BANDAI_ARCHIVES = ("dataset-1.tar.xz", "dataset-2.tar.xz")

# marker -> (what it needs, the environment variable that makes its absence a failure)
MARKERS: dict[str, tuple[str, str]] = {
    "requires_data": ("the Bandai Namco archives", "ARDY_REQUIRE_DATA"),
    "requires_prepared_data": ("the prepared dataset", ""),
    "requires_build": ("the built runtime", "ARDY_REQUIRE_BUILD"),
}

_running: list[pytest.Item] = []


def bandai_dir() -> Path:
    """The one place that decides where the Bandai Namco archives are."""
    configured = os.environ.get("ARDY_BANDAI_DIR")
    return Path(configured) if configured else REPO_ROOT.parent / "shared" / "data" / "bandai"


def processed_dir() -> Path:
    return REPO_ROOT / "data" / "processed"


def build_dir() -> Path:
    return REPO_ROOT / "build" / "template_debug"


def missing(marker: str) -> str | None:
    """Why a test with ``marker`` cannot run here, or None when it can."""
    if marker == "requires_data":
        root = bandai_dir()
        absent = [name for name in BANDAI_ARCHIVES if not (root / name).is_file()]
        if absent:
            return (
                f"Bandai Namco data not found at {root} (missing {', '.join(absent)}); "
                "set ARDY_BANDAI_DIR"
            )
    elif marker == "requires_prepared_data":
        if not (processed_dir() / "index.json").is_file():
            return f"prepared dataset not found at {processed_dir()}; run ardy-export data prepare"
    elif marker == "requires_build":
        cli = build_dir() / "src" / "ardy-generate"
        if not cli.is_file():
            return f"build not found ({cli} missing); run scripts/build.sh template_debug"
    return None


def _strict(marker: str) -> bool:
    variable = MARKERS[marker][1]
    return bool(variable) and os.environ.get(variable, "") not in ("", "0")


def require(marker: str) -> None:
    """Skips (or fails, where required) the running test when ``marker``'s need is absent.
    Helpers call it before touching the data; the test must carry the marker."""
    reason = missing(marker)
    if reason is None:
        return
    item = _running[-1] if _running else None
    if item is not None and item.get_closest_marker(marker) is None:
        pytest.fail(f"{item.nodeid} uses {MARKERS[marker][0]} without @pytest.mark.{marker}")
    _absent(marker, reason)


def _absent(marker: str, reason: str) -> None:
    if _strict(marker):
        pytest.fail(f"{reason} ({MARKERS[marker][1]}=1: required here)", pytrace=False)
    pytest.skip(reason)


def pytest_configure(config: pytest.Config) -> None:
    for marker, (need, variable) in MARKERS.items():
        strict = f"; a failure with {variable}=1" if variable else ""
        config.addinivalue_line("markers", f"{marker}: needs {need} (skipped without{strict})")


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    _running[:] = [item]  # before any fixture: module fixtures call require() too
    for marker in MARKERS:
        if item.get_closest_marker(marker) is not None:
            reason = missing(marker)
            if reason is not None:
                _absent(marker, reason)


@pytest.hookimpl(trylast=True)
def pytest_runtest_teardown(item: pytest.Item) -> None:
    _running.clear()


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT


@pytest.fixture(scope="session")
def foundation_dir(repo_root: Path) -> Path:
    return repo_root / "tests" / "data" / "foundation"


@pytest.fixture(scope="session")
def bandai_archives() -> Path:
    """The folder of the Bandai Namco archives (tests using it carry requires_data)."""
    require("requires_data")
    return bandai_dir()


@pytest.fixture(scope="session")
def build() -> Path:
    """build/template_debug (tests using it carry requires_build)."""
    require("requires_build")
    return build_dir()
