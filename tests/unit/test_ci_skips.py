"""On CI (``CI=true``) every test must run: one that would skip fails the run instead."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

CONFTEST = Path(__file__).parents[1] / "conftest.py"

SKIPPING = '''
import pytest

def test_that_needs_a_browser():
    pytest.skip("no Chromium on this machine")

def test_that_runs():
    pass
'''


def run_pytest(folder: Path, ci: bool, monkeypatch: pytest.MonkeyPatch) -> subprocess.CompletedProcess[str]:
    shutil.copy(CONFTEST, folder / "conftest.py")
    (folder / "test_skipping.py").write_text(SKIPPING)
    if ci:
        monkeypatch.setenv("CI", "true")
    else:
        monkeypatch.delenv("CI", raising=False)
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "--rootdir", str(folder), str(folder)],
                          capture_output=True, text=True, cwd=folder, timeout=120)


def test_a_skip_fails_the_run_on_ci(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    result = run_pytest(tmp_path, ci=True, monkeypatch=monkeypatch)
    assert result.returncode == 1
    assert "skipped on CI, where every test must run: Skipped: no Chromium" in result.stdout


def test_a_skip_is_a_skip_elsewhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    result = run_pytest(tmp_path, ci=False, monkeypatch=monkeypatch)
    assert result.returncode == 0
    assert "1 passed, 1 skipped" in result.stdout
