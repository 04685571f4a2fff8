"""scripts/test.sh counts the C++ suites by Catch2 test case (tests/cpp/count_cases.py)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

COUNT_CASES = Path(__file__).resolve().parents[2] / "tests" / "cpp" / "count_cases.py"


def _module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("count_cases", COUNT_CASES)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["count_cases"] = module
    spec.loader.exec_module(module)
    return module


def _xml(*cases: tuple[str, bool]) -> str:
    body = "".join(
        f'<TestCase name="{name}"><OverallResult success="{str(ok).lower()}"/></TestCase>'
        for name, ok in cases
    )
    return f'<?xml version="1.0"?><Catch2TestRun><Group>{body}</Group></Catch2TestRun>'


LOG = """\
      Start  1: test_a
 1/4 Test  #1: test_a ...........................   Passed    0.01 sec
 2/4 Test  #2: test_b ...........................***Failed    0.90 sec
 3/4 Test  #3: test_crash .......................***Exception: SegFault  0.20 sec
 4/4 Test  #4: test_c_api .......................   Passed    0.41 sec

75% tests passed, 2 tests failed out of 4
"""


def test_test_cases_are_counted_and_crashes_are_failures(tmp_path: Path) -> None:
    results = tmp_path / "catch2-results"
    results.mkdir()
    (results / "test_a.xml").write_text(_xml(("one", True), ("two", True), ("three", True)))
    (results / "test_b.xml").write_text(_xml(("four", True), ("five", False)))
    # Crashed after its cases passed (e.g. a sanitizer report at exit).
    (results / "test_crash.xml").write_text(_xml(("six", True)))
    passed, failed, problems = _module().count(tmp_path, LOG)
    # test_a: 3 cases; test_b: 1 + 1 failed; test_crash: 1 + a failure outside
    # its cases; test_c_api (no XML, not Catch2): 1.
    assert (passed, failed) == (3 + 1 + 1 + 1, 1 + 1)
    assert "test_b: test case failed: five" in problems
    assert any(p.startswith("test_crash: failed outside its test cases") for p in problems)


def test_a_suite_without_results_or_a_log_without_ctest_counts_as_failed(tmp_path: Path) -> None:
    (tmp_path / "catch2-results").mkdir()
    (tmp_path / "catch2-results" / "test_a.xml").write_text("<truncated")
    log = LOG.replace("   Passed", "***Failed", 1)  # test_a failed and left a broken XML
    passed, failed, problems = _module().count(tmp_path, log)
    # test_a: one failure; test_b and test_crash wrote nothing: one each; test_c_api passed.
    assert (passed, failed) == (1, 3)
    assert "test_a: no test case results (it crashed or ran none)" in problems
    assert _module().count(tmp_path, "no ctest here")[:2] == (0, 1)
