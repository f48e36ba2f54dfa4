"""The layer contracts (pyproject.toml, [tool.importlinter]): kept by the package, broken by an upward import or
by a command defined below the application layer; and every registered command's code lives in `nnda.app`.

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
    assert "2 kept, 0 broken" in run.stdout


@pytest.mark.parametrize("module, upward", [
    ("filters/kalman.py", "nnda.tracking.output"),  # a filter importing the trackers
    ("models/features.py", "nnda.tracking.gnn"),  # the model code importing a tracker
    ("study/compare.py", "nnda.reports.study_report"),  # the study stage importing its report
    ("reports/study_report.py", "nnda.app.cli"),  # a report importing the command line
    ("reports/pages.py", "typer"),  # a command defined in reports/
    ("data/dataset.py", "typer"),  # ... or in data/
])
def test_an_upward_import_breaks_the_contract(package_copy, module, upward):
    path = package_copy / "nnda" / module
    path.write_text(path.read_text() + f"\nimport {upward}  # noqa: E402\n")
    run = _lint(package_copy)
    assert run.returncode != 0
    assert "BROKEN" in run.stdout and upward in run.stdout


def test_every_command_is_defined_in_the_application_layer():
    from nnda.app.cli import app

    modules = {info.name or info.callback.__name__: info.callback.__module__ for info in app.registered_commands}
    assert len(modules) >= 13
    assert {name: m for name, m in modules.items() if not m.startswith("nnda.app.")} == {}
