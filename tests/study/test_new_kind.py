"""A new job kind is one module and one registry line: the study file, plan, keys, resume, records, aggregates,
checksums and a report section come with it (the kind of docs/extending/study-kind.md)."""

from __future__ import annotations

import json

import pytest
import random_walk_kind

from kind_study import run_kind
from nnda.errors import ConfigError
from nnda.reports.study_report import write_report
from nnda.study.compare import compare
from nnda.study.config import study_from_dict
from nnda.study.kinds import KINDS


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(KINDS, random_walk_kind.KIND.name, random_walk_kind.KIND)  # the one registry line


def test_a_new_kind_runs_from_its_table_and_is_reported(registered, tmp_path):
    result = run_kind(tmp_path / "out", "random_walk", {"runs": 30, "block_runs": 7}, seed=3)
    assert result["kalman_rmse"]["n"] == 30 and result["difference"]["ci_high"] < 0  # the filter beats the raw fixes
    assert result["raw_rmse"]["ci_low"] <= 2.0 <= result["raw_rmse"]["ci_high"]  # sqrt(r)
    sums = json.loads((tmp_path / "out" / "checksums.json").read_text())["sha256"]
    assert {"random_walk.parquet", "summary.json"} <= set(sums)
    page = write_report(tmp_path / "out")  # no section of its own: the table of its aggregates
    md = page.with_name("report.md").read_text()
    assert "## random_walk jobs" in md and "kalman_rmse.mean" in md


def test_blocks_and_resume_do_not_change_its_results(registered, tmp_path):
    one = run_kind(tmp_path / "a", "random_walk", {"runs": 12, "block_runs": 12})
    blocks = run_kind(tmp_path / "b", "random_walk", {"runs": 12, "block_runs": 5})
    assert one == blocks
    again = compare(study_from_dict({"name": "random_walk", "random_walk": {"runs": 12, "block_runs": 5}}, "t"),
                    tmp_path / "b", resume=True, workers=1)
    assert again.execution.jobs_run == 0 and again.execution.jobs_skipped == 3


def test_its_table_is_checked_like_every_other(registered):
    with pytest.raises(ConfigError, match=r"random_walk.runs: Input should be greater than or equal to 2"):
        study_from_dict({"random_walk": {"runs": 1}}, "s.toml")


def test_without_the_registry_line_the_study_file_refuses_the_table():
    with pytest.raises(ConfigError, match="random_walk: Extra inputs are not permitted"):
        study_from_dict({"random_walk": {"runs": 4}}, "s.toml")
