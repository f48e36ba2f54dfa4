"""A P_D learnt from the confirmed tracks (``lifecycle.estimate_pd``): where neither the tracker config nor the
sensor gives one, the score's P_D is the assumed value lowered, never raised, to the tracks' detection record."""

from __future__ import annotations

import re

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.study.track import run_tracker
from nnda.study.track_job import scalars, series
from nnda.study.track_results import results_table
from nnda.tracking.detection_probability import PRIOR_SCANS, DetectionProbabilities, DetectionRecord
from nnda.tracking.output import NO_CONTACT, TrackStatus
from nnda.tracking.registry import make_tracker

#: the trackers that learn (lmb has GLMB's update; the neural tracker does not learn: `NeuralTracker.learns_pd`)
LEARNING = ["gnn", "jpda", "mht", "pmbm", "glmb"]


def _s1(pd: float, declared: float | None = None, seed: int = 0):
    """S1 with its radar detecting each target with probability ``pd`` (and declaring ``declared``)."""
    scenario = preset("S1")
    radar = scenario.sensor.model_copy(update={"pd": pd, "declared_pd": declared})
    return generate(scenario.model_copy(update={"sensors": (radar,)}), seed=seed, run=0)


def _run(name: str, dataset, params: dict | None = None):
    tracker = make_tracker(name, dataset.scenario.sensors, params or {})
    outputs = [tracker.step(scan) for scan in dataset.scans()]
    return tracker, outputs


def test_the_record_lowers_the_assumed_pd_to_the_hit_rate_and_never_raises_it():
    record = DetectionRecord(DetectionProbabilities(("a", "b"), (0.9, 0.9), ("", "")), [True, False])
    record.add(0, 8, 10)
    assert record[0] == pytest.approx((8 + PRIOR_SCANS * 0.9) / (10 + PRIOR_SCANS), rel=1e-12)
    record.add(0, 0, 0)  # no confirmed track observed: nothing learnt
    assert record[0] == pytest.approx((8 + PRIOR_SCANS * 0.9) / (10 + PRIOR_SCANS), rel=1e-12)
    record.add(0, 100, 100)
    assert record[0] == 0.9  # a record above the assumed value leaves it
    record.add(1, 0, 50)  # a sensor not learnt keeps its value
    assert record[1] == 0.9 and record.record() == [0.9, None]
    record.add(0, 0, 200)
    assert record[0] == pytest.approx((108 + PRIOR_SCANS * 0.9) / (310 + PRIOR_SCANS), rel=1e-12)
    record.reset()
    assert record[0] == 0.9 and record.observed == [0, 0]


@pytest.mark.parametrize("name", LEARNING)
def test_a_tracker_learns_its_radars_pd_and_stays_at_the_assumed_one_above_it(name):
    faded = _run(name, _s1(0.7))[0]
    learnt = faded.track_management()["learnt_pd"][0]
    assert 0.6 < learnt < 0.75, learnt  # the record counts the misses of tracks coasting to their deletion too
    assert faded.score_pd(0) == learnt
    sharp = _run(name, _s1(1.0))[0]
    assert sharp.track_management()["learnt_pd"] == [0.9]


def test_the_record_counts_the_confirmed_tracks_observed_scans_and_their_contacts():
    """GNN's record against a recount from its own output (one sensor: every scan observes every track)."""
    tracker, outputs = _run("gnn", _s1(0.7, seed=1))
    hits = observed = 0
    confirmed: set[int] = set()
    for out in outputs:
        was = np.isin(out.track_id, list(confirmed))
        observed += int(was.sum())
        hits += int((was & (out.contact != NO_CONTACT)).sum())
        confirmed = set(out.track_id[out.status == TrackStatus.CONFIRMED].tolist())
    assert observed > 100
    assert (tracker.pd_record.hits[0], tracker.pd_record.observed[0]) == (hits, observed)


@pytest.mark.parametrize("name", LEARNING)
def test_a_declared_or_configured_pd_and_the_mn_rule_are_not_learnt(name):
    dataset = _s1(0.7, declared=0.7)
    declared = _run(name, dataset)[0]
    assert "learnt_pd" not in declared.track_management() and declared.score_pd(0) == 0.7
    plain = _s1(0.7)
    fixed = [{"lifecycle": {"estimate_pd": False}}]
    if name in ("gnn", "jpda", "mht"):  # the labelled trackers confirm by their existence, never by M/N
        fixed.append({"lifecycle": {"confirmation": "mn"}})
    for params in fixed:
        tracker = _run(name, plain, params)[0]
        assert "learnt_pd" not in tracker.track_management() and tracker.score_pd(0) == 0.9
    if name != "gnn":  # gnn has no pd field
        assert "learnt_pd" not in _run(name, plain, {"pd": 0.9})[0].track_management()


def test_a_learnt_pd_moves_the_run_and_a_reset_forgets_it():
    dataset = _s1(0.7)
    tracker, first = _run("gnn", dataset)
    fixed = _run("gnn", dataset, {"lifecycle": {"estimate_pd": False}})[1]
    assert any(a.track_id.tobytes() != b.track_id.tobytes() or a.state.tobytes() != b.state.tobytes()
               for a, b in zip(first, fixed))
    tracker.reset()
    assert tracker.score_pd(0) == 0.9
    again = [tracker.step(scan) for scan in dataset.scans()]
    assert all(a.state.tobytes() == b.state.tobytes() for a, b in zip(first, again))


def test_the_results_table_has_the_learnt_pd_only_where_a_tracker_learns():
    dataset = _s1(0.7)
    runs = [run_tracker(dataset, "gnn", params) for params in ({}, {"lifecycle": {"confirmation": "mn"}})]
    base = {"scenario": "s1", "tracker": "gnn", "kind": "gnn", "run": 0, "seed": 0, "dataset_digest": "d",
            "n_scans": dataset.n_scans, "n_targets": 1, "ownership": "contacts"}
    records = [base | {"metrics": scalars(r.scores), "series": series(r.scores), "track_management": r.management}
               for r in runs]
    column = results_table(records).column("learnt_pd").to_pylist()
    assert column[1] is None and 0.6 < column[0][0] < 0.75
    assert "learnt_pd" not in results_table(records[1:]).column_names


def test_nnda_track_says_the_learnt_pd_and_whether_it_stayed_as_assumed(tmp_path):
    from typer.testing import CliRunner

    from nnda.app.cli import app
    from nnda.data.dataset import write_dataset

    faded = write_dataset(_s1(0.7), tmp_path / "faded")
    sharp = write_dataset(_s1(1.0), tmp_path / "sharp")
    said = {}
    for name, data in (("faded", faded), ("sharp", sharp)):
        done = CliRunner().invoke(app, ["track", str(data), "--tracker", "gnn", "--out", str(tmp_path / f"t-{name}"),
                                        "--quiet"])
        assert done.exit_code == 0, done.output
        said[name] = " ".join(done.output.split())  # the console wraps long lines
    learnt = re.search(r"gnn: P_D learnt from the confirmed tracks by the run's end: radar (\S+)", said["faded"])
    assert 0.6 < float(learnt.group(1)) < 0.75 and "as assumed" not in said["faded"]
    assert ("gnn: P_D learnt from the confirmed tracks by the run's end: radar 0.900 (as assumed: their record is "
            "not below it)") in said["sharp"]


def test_the_neural_tracker_keeps_the_assumed_pd(model_file):
    """Its tracks' missing contacts are the network's refusals as often as the radar's misses."""
    tracker = _run("nn", _s1(0.7), {"model": str(model_file)})[0]
    assert not any(tracker.pd_record.learn) and "learnt_pd" not in tracker.track_management()
    assert tracker.score_pd(0) == 0.9
