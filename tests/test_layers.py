"""The layer contract (pyproject.toml, [tool.importlinter]): kept by the package, broken by an upward import.

Both checks run import-linter in a subprocess on a copy of the package, so
the second can add an import that points up a layer without touching the
source tree.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")

pytestmark = pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter is not installed (dev extra)")


def _lint(src: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(src)}
    return subprocess.run([str(LINT_IMPORTS), "--no-cache", "--config", str(ROOT / "pyproject.toml")],
                          capture_output=True, text=True, env=env, cwd=src)


@pytest.fixture
def package_copy(tmp_path) -> Path:
    shutil.copytree(ROOT / "src" / "nnda", tmp_path / "nnda", ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path


def test_the_package_keeps_its_layers(package_copy):
    run = _lint(package_copy)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "1 kept, 0 broken" in run.stdout


@pytest.mark.parametrize("module, upward", [
    ("filters/kalman.py", "nnda.tracking.output"),  # a filter importing the trackers
    ("models/features.py", "nnda.tracking.gnn"),  # the model code importing a tracker
    ("study/compare.py", "nnda.reports.study_report"),  # the study stage importing its report
])
def test_an_upward_import_breaks_the_contract(package_copy, module, upward):
    path = package_copy / "nnda" / module
    path.write_text(path.read_text() + f"\nimport {upward}  # noqa: E402\n")
    run = _lint(package_copy)
    assert run.returncode != 0
    assert "BROKEN" in run.stdout and upward in run.stdout
