"""A study with a tracker's fixed lag: records, results, summary and report carry the lagged measures beside
the online ones; without a lag everything is as it was."""

from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest

from nnda.errors import ConfigError
from nnda.reports.study_tables import scenario_table
from nnda.reports.text_table import DASH, stat_cell
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.study.measures import RUN_MEASURES, SERIES_MEASURES
from nnda.study.plan import plan_study
from nnda.study.results import read_summary


def _two_runs(root, write_study, lag: str) -> object:
    """The small study with two runs, one scenario; ``lag`` goes into the gnn-tight tracker's table."""
    study_file = write_study(root, runs=2, duration=30)
    text = study_file.read_text().replace('params = { gate = 6.0 }', f'params = {{ gate = 6.0 }}\n{lag}')
    text = text.replace('[[scenarios]]\nconfig = "scenarios/two.toml"\n', "")
    study_file.write_text(text)
    return study_file


@pytest.fixture(scope="module")
def studies(tmp_path_factory, write_study):
    """The same study without a lag and with lag = 2 on one tracker, run in this process."""
    runs = {}
    for name, lag in (("online", ""), ("lagged", "lag = 2")):
        root = tmp_path_factory.mktemp(name)
        study_file = _two_runs(root, write_study, lag)
        compare(load_study(study_file), root / "out", workers=1)
        runs[name] = (study_file, root / "out")
    return runs


def test_records_and_results_carry_the_lagged_measures(studies):
    _, out = studies["lagged"]
    record = json.loads(next((out / "jobs" / "one" / "gnn-tight").glob("run-0000.json")).read_text())
    late = record["lagged"]
    assert late["lag"] == 2
    assert set(late["metrics"]) == set(record["metrics"])
    assert set(late["series"]) == set(record["series"])
    assert len(record["timing"]["lag_time_per_scan_s"]) == record["n_scans"]
    plain = json.loads(next((out / "jobs" / "one" / "gnn").glob("run-0000.json")).read_text())
    assert "lagged" not in plain and "lag_time_per_scan_s" not in plain["timing"]
    res = pq.read_table(out / "results.parquet").to_pydict()
    assert res["tracker"] == ["gnn", "gnn", "gnn-tight", "gnn-tight"]
    assert res["lag"] == [0, 0, 2, 2]
    for m in RUN_MEASURES:
        assert res[f"lag_{m.key}"][:2] == [None, None]
    assert res["lag_gospa"][2] == pytest.approx(late["metrics"]["gospa"])
    assert all(len(s) == record["n_scans"] for s in res[f"lag_{SERIES_MEASURES[0].series_name}_per_scan"][2:])
    # the back-fill of confirmations: the lagged output confirms the targets sooner
    assert late["metrics"]["mean_time_to_confirm_s"] < record["metrics"]["mean_time_to_confirm_s"]
    summary = json.loads((out / "summary.json").read_text())
    trackers = summary["scenarios"][0]["trackers"]
    assert "lagged" not in trackers["gnn"]
    assert trackers["gnn-tight"]["lagged"]["lag"] == 2
    assert trackers["gnn-tight"]["lagged"]["metrics"]["gospa"]["n"] == 2
    timing = json.loads((out / "timing.json").read_text())
    assert "lagged" in timing["scenarios"][0]["trackers"]["gnn-tight"]


def test_the_report_table_shows_the_lagged_column_beside_the_online_one(studies):
    _, out = studies["lagged"]
    summary, timing = read_summary(out)
    table = scenario_table(summary["scenarios"][0], timing["scenarios"][0], False, 0.95)
    assert table.header == ("Measure", "gnn", "gnn-tight", "gnn-tight lag 2")
    gospa = next(row for row in table.rows if row[0].startswith("GOSPA,"))
    late = summary["scenarios"][0]["trackers"]["gnn-tight"]["lagged"]["metrics"]
    assert gospa[3] == stat_cell(late["gospa"], "{:.1f}")
    assert gospa[3] != gospa[2]
    time = next(row for row in table.rows if row[0].startswith("Time per scan"))
    assert time[3] != DASH and time[3] != time[2]  # the revision's own time
    assert "lag L" in table.note
    online, _ = read_summary(studies["online"][1])
    plain = scenario_table(online["scenarios"][0], timing["scenarios"][0], False, 0.95)
    assert plain.header == ("Measure", "gnn", "gnn-tight") and "lag L" not in plain.note


def test_without_a_lag_the_results_and_job_keys_are_as_before(studies):
    study_file, out = studies["online"]
    res = pq.read_table(out / "results.parquet")
    assert not [c for c in res.column_names if c == "lag" or c.startswith("lag_")]
    summary = (out / "summary.json").read_text()
    assert '"lagged"' not in summary
    # the online measures of the lagged study equal the study without lags, row for row
    lagged = pq.read_table(studies["lagged"][1] / "results.parquet")
    assert lagged.select(res.column_names).drop(["tracker"]).equals(res.drop(["tracker"]))
    # an explicit lag = 0 is the study without one: the same job keys, the same study record
    zero = study_file.parent / "zero.toml"
    zero.write_text(study_file.read_text().replace("params = { gate = 6.0 }", "params = { gate = 6.0 }\nlag = 0"))
    a, b = plan_study(load_study(study_file)), plan_study(load_study(zero))
    assert [j.key for j in a.jobs] == [j.key for j in b.jobs]
    assert load_study(study_file).model_dump(mode="json") == load_study(zero).model_dump(mode="json")
    lag2 = plan_study(load_study(studies["lagged"][0]))
    for before, after in zip(a.jobs, lag2.jobs, strict=True):  # only gnn-tight's lag enters its jobs' keys
        assert (before.key == after.key) == (before.spec.tracker == "gnn")


@pytest.mark.parametrize("value", ["-1", "2.5", '"3"', "101"])
def test_a_bad_lag_names_the_tracker_and_the_field(tmp_path, write_study, value):
    study_file = _two_runs(tmp_path, write_study, f"lag = {value}")
    with pytest.raises(ConfigError, match=r"trackers.gnn-tight.lag"):
        load_study(study_file)
