"""The per-scan target counts of a study: recorded by every tracker job, the PHD filters' own estimates
beside, written to cardinality.parquet and read back; job records of the format before are refused."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pyarrow.parquet as pq
import pytest

from count_study import count_study
from nnda.data.generator import generate
from nnda.data.scenario import load_scenario
from nnda.errors import DatasetError
from nnda.study.cardinality import CARDINALITY_FILE, read_cardinality, snapshot
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.study.plan import plan_study
from nnda.study.runner import JOB_FORMAT_VERSION, is_done, read_job
from nnda.tracking.phd.tracker import Cardinality
from nnda.tracking.registry import make_tracker
from tolerances import RTOL


@pytest.fixture(scope="module")
def counted(tmp_path_factory, write_study):
    root = tmp_path_factory.mktemp("counts")
    write_study(root, runs=2)
    (root / "counts.toml").write_text(count_study("scenarios/one.toml", runs=2, seed=5))
    study = load_study(root / "counts.toml")
    compare(study, root / "out", workers=1)
    return root, study, root / "out"


def test_every_job_records_the_true_and_estimated_counts_and_the_filters_own(counted):
    root, _, out = counted
    table = pq.read_table(out / CARDINALITY_FILE).to_pydict()
    assert list(zip(table["tracker"], table["run"])) == [("gnn", 0), ("gnn", 1), ("ekphd", 0), ("ekphd", 1),
                                                         ("cphd", 0), ("cphd", 1)]
    results = pq.read_table(out / "results.parquet").to_pydict()
    scenario = load_scenario(root / "scenarios/one.toml")
    for i, (kind, run) in enumerate(zip(table["kind"], table["run"])):
        ds = generate(scenario, 5, run)
        tracker = make_tracker(kind, ds.scenario.sensors)
        confirmed, mean, map_, var = [], [], [], []
        for scan in ds.scans():
            out_ = tracker.step(scan)
            confirmed.append(int((out_.status == 2).sum()))
            c = getattr(tracker, "cardinality", None)
            if c is not None:
                mean.append(c.mean)
                map_.append(c.map)
                if c.distribution is not None:
                    n = np.arange(c.distribution.size)
                    var.append(float(n**2 @ c.distribution - (n @ c.distribution) ** 2))
        true = np.bincount(ds.truth.scan - 1, minlength=ds.n_scans)
        assert table["true_count"][i] == true.tolist()
        assert table["confirmed_count"][i] == confirmed
        # the count error of results.parquet is the same |confirmed - true|
        assert results["count_error_per_scan"][i] == np.abs(np.array(confirmed) - true).astype(float).tolist()
        if kind == "gnn":
            assert table["filter_mean"][i] is table["filter_map"][i] is table["filter_variance"][i] is None
            continue
        np.testing.assert_allclose(table["filter_mean"][i], mean, rtol=RTOL)
        if kind == "ekphd":  # a PHD has no MAP count and no distribution
            assert table["filter_map"][i] is None and table["filter_variance"][i] is None
        else:
            assert table["filter_map"][i] == map_
            np.testing.assert_allclose(table["filter_variance"][i], var, rtol=RTOL, atol=1e-12)
            assert min(table["filter_variance"][i]) >= 0


def test_read_cardinality_gives_runs_by_scans_arrays(counted):
    _, _, out = counted
    counts = read_cardinality(out)
    assert list(counts) == [("one", "gnn"), ("one", "ekphd"), ("one", "cphd")]
    cphd, gnn = counts["one", "cphd"], counts["one", "gnn"]
    assert cphd.runs == 2 and cphd.kind == "cphd" and cphd.true.shape == cphd.filter_variance.shape == (2, 20)
    assert gnn.filter_mean is None and counts["one", "ekphd"].filter_map is None
    assert np.array_equal(cphd.true, gnn.true)  # every tracker saw the same data
    np.testing.assert_array_equal(cphd.filter_map, np.round(cphd.filter_map))


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(DatasetError, match=r"cardinality.parquet: missing \(run the study to completion"):
        read_cardinality(tmp_path)


def test_job_records_of_the_previous_format_are_rerun_and_refused(counted, tmp_path):
    _, study, out = counted
    job = plan_study(study).jobs[0]
    record = json.loads((out / job.relpath).read_text())
    assert record["format_version"] == JOB_FORMAT_VERSION == 5 and set(record["cardinality"]) == {
        "true", "confirmed", "filter_mean", "filter_map", "filter_variance"}
    old = tmp_path / job.relpath
    old.parent.mkdir(parents=True)
    old.write_text(json.dumps({**record, "format_version": 4}))
    assert is_done(job, out) and not is_done(job, tmp_path)
    with pytest.raises(DatasetError, match=r"run-0000.json: field 'format_version' is 4; this nnda .* reads "
                                           r"version 5 only"):
        read_job(job, tmp_path)


def test_a_count_given_as_mean_and_variance_is_recorded_without_a_distribution():
    """The labelled trackers give their count's variance directly (no distribution): the snapshot keeps it;
    a record of another scan gives nothing."""
    tracker = SimpleNamespace(cardinality=Cardinality(4, 8.0, 2.5, None, None, 2, variance=0.35))
    assert snapshot(tracker, 4) == (2.5, None, 0.35)
    assert snapshot(tracker, 5) is None
    tracker.cardinality = Cardinality(4, 8.0, 1.0, 1, np.array([0.25, 0.5, 0.25]), 1)
    assert snapshot(tracker, 4) == (1.0, 1, 0.5)
