"""nnda's core works without its optional dependencies: with torch and scikit-learn (``nnda[train]``) and
filterpy (the tests' reference) made unimportable, generating, importing, tracking, a study and its report
all run, and training says which extra to install.

The packages are hidden by a ``sitecustomize`` on PYTHONPATH that refuses to import them, so this
checks the code's imports, not only the declared dependencies.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

NNDA = Path(sys.executable).with_name("nnda")
HIDDEN = ("torch", "sklearn", "filterpy")
BLOCKER = f"""
import sys
class _Hidden:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {HIDDEN!r}:
            raise ImportError(f"{{name}} is hidden by the core-install test")
sys.meta_path.insert(0, _Hidden())
"""

STUDY = """name = "core"
seed = 1
runs = 1
[trackers.gnn]
kind = "gnn"
[trackers.mht]
kind = "mht"
[[scenarios]]
preset = "S1"
"""


@pytest.fixture
def core(tmp_path):
    """Run ``nnda ARGS`` in tmp_path with the optional packages hidden; returns the finished process."""
    (tmp_path / "hide").mkdir()
    (tmp_path / "hide" / "sitecustomize.py").write_text(BLOCKER)
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "hide"), "MPLBACKEND": "Agg"}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(NNDA), *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)

    return run


def test_the_core_tracks_studies_and_reports_without_torch_or_scikit_learn(core, tmp_path):
    hidden = core("generate", "--preset", "S1", "--out", "s1")
    assert hidden.returncode == 0, hidden.stderr
    assert core("track", "s1", "--tracker", "mht", "--out", "t").returncode == 0
    assert (tmp_path / "t" / "tracks.parquet").exists()
    (tmp_path / "core.toml").write_text(STUDY)
    done = core("run", "--study", "core.toml", "--out", "study", "--jobs", "1")
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "study" / "report.html").exists()


def test_training_without_torch_names_the_extra(core):
    assert core("generate", "--preset", "train01", "--out", "t1").returncode == 0
    done = core("train", "--data", "t1", "--out", "m")
    assert done.returncode == 2
    assert 'pip install "nnda[train]"' in done.stderr and "Traceback" not in done.stderr


def test_every_package_the_code_imports_is_declared():
    """Each third-party package imported anywhere in src/nnda is a dependency of the core or of an extra (a
    package that only arrives with another, as threadpoolctl did with scikit-learn, breaks a clean install)."""
    import ast
    import re
    import tomllib
    from importlib.metadata import packages_distributions

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    declared = {re.split(r"[<>=\[;! ]", d, maxsplit=1)[0].lower().replace("_", "-")
                for d in [*project["dependencies"], *sum(project["optional-dependencies"].values(), [])]}
    dists = packages_distributions()
    missing = {}
    for path in sorted((root / "src" / "nnda").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module
                     else [])
            for name in names:
                top = name.split(".")[0]
                if top == "nnda" or top in sys.stdlib_module_names:
                    continue
                owners = {d.lower().replace("_", "-") for d in dists.get(top, [top])}
                if not owners & declared:
                    missing.setdefault(top, str(path.relative_to(root)))
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"
