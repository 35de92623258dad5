"""Shared test fixtures: where the examples and the (optional) real racer files live."""

from __future__ import annotations

import os
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest

REPO_ROOT = Path(__file__).parents[1]
EXAMPLES_DIR = REPO_ROOT / "examples"
# Real racer files shared next to the repository; the project must work without them.
FIXTURES_DIR = Path(__file__).parents[1].parent / "shared" / "fixtures"


@pytest.fixture(scope="session")
def examples_dir() -> Path:
    return EXAMPLES_DIR


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    if not FIXTURES_DIR.is_dir():
        pytest.skip(f"real racer files not present at {FIXTURES_DIR}")
    return FIXTURES_DIR


@pytest.fixture(autouse=True)
def user_dirs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Every test gets its own user folders: no test reads or writes the real ones."""
    home = tmp_path / "user"
    monkeypatch.setenv("XDG_DATA_HOME", str(home / "data"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(home / "config"))
    for variable in ("DRBOARD_DB", "DRBOARD_RACER", "DRBOARD_ENDPOINT"):
        monkeypatch.delenv(variable, raising=False)
    return home


def on_ci() -> bool:
    """CI sets ``CI=true``: there every test must run, so a skip is a failure."""
    return os.environ.get("CI") == "true"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, Any, None]:
    outcome = yield
    _fail_skips_on_ci(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> Generator[None, Any, None]:
    outcome = yield
    _fail_skips_on_ci(outcome.get_result())


def _fail_skips_on_ci(report: pytest.TestReport | pytest.CollectReport) -> None:
    if on_ci() and report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        report.outcome = "failed"
        report.longrepr = f"skipped on CI, where every test must run: {reason}"
