"""Fixtures of the bad-input suite: the command line run as a user runs it, tiny inputs, before/after stock.

`nnda` runs in this process through `nnda.app.cli.main` (the entry point of
``python -m nnda``: the same error handling and exit status) with the
working directory set, so a case costs milliseconds rather than a new
interpreter; each module also runs one case as a real subprocess. Every
refusal is checked the same way (`refused`): exit status 2, one line
on stderr starting "error:" that holds the given fragments (what and where),
no traceback, and every file and directory under the watched root, hidden
ones included, byte for byte as before.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest
from cli_run import TINY, Outcome, assert_one_line_error

from dataset_edits import snapshot
from nnda.app.cli import main
from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.data.scenario import scenario_from_dict


@pytest.fixture
def nnda(monkeypatch, capsys):
    """``nnda(*args, cwd=dir)``: run the command line in this process; returns its `Outcome`."""
    def run(*args, cwd: Path) -> Outcome:
        capsys.readouterr()
        with monkeypatch.context() as m:
            m.chdir(cwd)
            m.setattr(sys, "argv", ["nnda", *map(str, args)])
            with pytest.raises(SystemExit) as done:
                main()
        captured = capsys.readouterr()
        return Outcome(done.value.code, captured.out, captured.err)
    return run


@pytest.fixture
def refused(nnda):
    """``refused(root, *args, fragments=(...), cwd=root)``: the command is refused (`assert_one_line_error`) and
    nothing under ``root`` changed; returns the outcome."""
    def check(root: Path, *args, fragments: tuple[str, ...], cwd: Path | None = None) -> Outcome:
        before = snapshot(root)
        outcome = nnda(*args, cwd=cwd or root)
        assert_one_line_error(outcome, *fragments)
        after = snapshot(root)
        assert after.keys() == before.keys(), sorted(after.keys() ^ before.keys())
        assert after == before, [k for k in before if before[k] != after[k]]
        return outcome
    return check


@pytest.fixture(scope="session")
def tiny_dataset_source(tmp_path_factory) -> Path:
    return write_dataset(generate(scenario_from_dict(TINY)), tmp_path_factory.mktemp("tiny") / "ds")


@pytest.fixture
def tiny_dataset(tmp_path, tiny_dataset_source) -> Path:
    """A fresh copy of the written tiny dataset, ``tmp_path / "ds"``."""
    return Path(shutil.copytree(tiny_dataset_source, tmp_path / "ds"))
