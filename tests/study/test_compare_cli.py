"""`nnda compare` as a user runs it: a real process, real files."""

from __future__ import annotations

import subprocess
import sys


def nnda(*args, cwd):
    return subprocess.run([sys.executable, "-m", "nnda", *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          timeout=300)


def test_compare_runs_the_study_and_prints_the_report_path(small_study, tmp_path):
    run = nnda("compare", "--study", small_study, "--out", "out", "--jobs", "1", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "12 job(s) run, 0 resumed, on in-process" in run.stdout
    assert "report: out/report.html" in run.stdout and (tmp_path / "out/report.html").is_file()
    again = nnda("compare", "--study", small_study, "--out", "out", "--resume", cwd=tmp_path)
    assert again.returncode == 0 and "0 job(s) run, 12 resumed" in again.stdout


def test_cli_prints_one_clear_line_and_writes_nothing(tmp_path):
    (tmp_path / "s.toml").write_text('[trackers.x]\nkind = "telepathy"\n[[scenarios]]\npreset = "S1"\n')
    run = nnda("compare", "--study", "s.toml", "--out", "out", cwd=tmp_path)
    assert run.returncode == 2
    assert "s.toml: tracker 'x': unknown tracker 'telepathy'" in run.stderr and "Traceback" not in run.stderr
    assert not (tmp_path / "out").exists()
