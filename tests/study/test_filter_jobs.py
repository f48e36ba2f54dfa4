"""Filter jobs: single-target filters beside the trackers, through the same plan, keys, resume and workers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.errors import ConfigError
from nnda.filters.single_target import make_filter
from nnda.reports.study_report import write_report
from nnda.study.compare import compare
from nnda.study.config import study_from_dict
from nnda.study.plan import plan_study

ONE = Scenario(name="one", duration_s=60.0, clutter=Clutter(count=20), targets=[
    Target(name="turner", x_m=-8_000.0, y_m=12_000.0, heading_deg=90.0, speed_m_s=150.0,
           segments=[Segment(duration_s=30.0), Segment(duration_s=30.0, normal_accel=30.0)])])
TWO = Scenario(name="two", duration_s=20.0, clutter=Clutter(count=10), targets=[
    ONE.targets[0], ONE.targets[0].model_copy(update={"name": "other", "y_m": -12_000.0})])


def _study(tmp_path, filters, trackers=None, scenarios=("one.json", "two.json"), runs=3) -> object:
    for sc in (ONE, TWO):
        (tmp_path / f"{sc.name}.json").write_text(sc.model_dump_json())
    return study_from_dict({"name": "filters", "runs": runs, "seed": 2,
                            "trackers": trackers if trackers is not None else {"gnn": {"kind": "gnn"}},
                            "filters": filters, "scenarios": [{"config": s} for s in scenarios]}, base=tmp_path)


FILTERS = {"imm": {"kind": "imm"}, "cv": {"kind": "imm", "params": {"motion": "cv"}}}


def test_filters_run_on_the_single_target_scenarios_and_are_scored(tmp_path):
    result = compare(_study(tmp_path, FILTERS), tmp_path / "out", workers=1)
    summary = result.summary
    assert [s["name"] for s in summary["filters"]] == ["one"]  # "two" has two targets
    imm, cv = (summary["filters"][0]["filters"][k]["metrics"] for k in ("imm", "cv"))
    assert imm["position_rmse_m"]["mean"] < 60.0 and imm["velocity_rmse_m_s"]["mean"] < 40.0
    assert 2.0 < imm["nees"]["mean"] < 8.0  # about 4 when consistent
    assert cv["divergence_pct"]["mean"] > imm["divergence_pct"]["mean"]  # CV alone cannot follow the turn
    assert imm["start_s"]["mean"] == pytest.approx(2.0)  # estimates from the second contact on
    assert (tmp_path / "out" / "filter_results.parquet").is_file()
    report = write_report(tmp_path / "out")
    text = report.with_name("report.md").read_text()
    assert "## Single-target filters" in text and "one: single-target filters" in text
    assert summary["scenarios"][0]["trackers"]["gnn"]["runs"] == 3  # the trackers ran as before


def test_tracker_jobs_keep_their_keys_beside_filters(tmp_path):
    with_filters = plan_study(_study(tmp_path, FILTERS))
    without = plan_study(_study(tmp_path, {}))
    tracks = [j.key for j in with_filters.jobs if j.kind == "track"]
    assert tracks == [j.key for j in without.jobs]
    assert sum(j.kind == "filter" for j in with_filters.jobs) == 2 * 3  # two filters x three runs of "one"


def test_resume_and_workers_give_the_same_bytes(tmp_path):
    study = _study(tmp_path, FILTERS, runs=2)
    compare(study, tmp_path / "a", workers=1)
    compare(study, tmp_path / "b", workers=2)
    for name in ("summary.json", "filter_results.parquet", "results.parquet"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    job = next((tmp_path / "a" / "jobs" / "one" / "imm").glob("run-*.json"))
    job.unlink()
    resumed = compare(study, tmp_path / "a", resume=True, workers=1)
    assert resumed.execution.jobs_run == 1
    assert json.loads((tmp_path / "a" / "summary.json").read_text()) == json.loads(
        (tmp_path / "b" / "summary.json").read_text())


def test_a_filter_only_study(tmp_path):
    result = compare(_study(tmp_path, {"imm": {"kind": "imm"}}, trackers={}, scenarios=("one.json",)),
                     tmp_path / "out", workers=1)
    assert result.summary["filters"][0]["filters"]["imm"]["runs"] == 3
    write_report(tmp_path / "out")


@pytest.mark.parametrize("filters, scenarios, message", [
    ({"imm": {"kind": "kalman"}}, ("one.json",), "filter 'imm': unknown filter 'kalman'; choose one of imm"),
    ({"imm": {"kind": "imm", "params": {"motion": "ct"}}}, ("one.json",), "motion"),
    (FILTERS, ("two.json",), "filters run on single-target scenarios, and this study has none .*two \\(2\\)"),
])
def test_bad_filters_are_refused_at_planning(tmp_path, filters, scenarios, message):
    with pytest.raises(ConfigError, match=message):
        plan_study(_study(tmp_path, filters, scenarios=scenarios))


def test_a_label_names_a_tracker_or_a_filter(tmp_path):
    with pytest.raises(ConfigError, match="gnn name both a tracker and a filter"):
        _study(tmp_path, {"gnn": {"kind": "imm"}})
    with pytest.raises(ConfigError, match="name what to run"):
        _study(tmp_path, {}, trackers={})


def test_the_imm_filter_follows_a_noise_free_line_exactly_enough():
    """Two contacts start it at the second one; on a straight line at PD 1 its error stays small."""
    f = make_filter("imm", ONE.sensors, {"motion": "cv"})
    t = np.arange(1, 21) * 2.0
    x, y = -8_000.0 + 150.0 * t, np.full(t.size, 12_000.0)
    r, az = np.hypot(x, y), np.arctan2(x, y) % (2 * np.pi)
    assert f.step(t[0], 0, np.array([r[0], az[0]])) is None
    est = [f.step(tk, 0, np.array([rk, ak])) for tk, rk, ak in zip(t[1:], r[1:], az[1:])]
    assert np.hypot(est[-1].x[0] - x[-1], est[-1].x[2] - y[-1]) < 1.0
    assert abs(est[-1].x[1] - 150.0) < 1.0
    missed = f.step(t[-1] + 2.0, 0, None)  # a miss: the prediction
    assert missed.x[0] == pytest.approx(est[-1].x[0] + 2.0 * est[-1].x[1])
