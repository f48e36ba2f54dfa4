"""`nnda track` and `nnda.track`: the study's job on one dataset, its table, files and scores."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.csv as pacsv
import pytest
from typer.testing import CliRunner

import nnda
from nnda.app.cli import app
from nnda.data.dataset import write_dataset
from nnda.data.detections_import import export_detections, import_detections, sensor_specs
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.data.sources import GeneratedScenes
from nnda.models.feature_sets import feature_set
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, save_model
from nnda.study.kinds.track import TrackJob
from nnda.study.track import COV_COLUMNS, TRACK_SCHEMA, run_tracker, tracker_params
from nnda.study.track_job import run_job, scalars
from nnda.tracking.neural import life5
from nnda.tracking.output import TrackStatus

SEED = 4


@pytest.fixture(scope="module")
def s1():
    return generate(preset("S1"), seed=SEED, run=0)


@pytest.fixture(scope="module")
def s1_dir(s1, tmp_path_factory):
    return write_dataset(s1, tmp_path_factory.mktemp("s1") / "S1")


def _job(kind: str, params: dict) -> dict:
    return run_job(TrackJob(scenario="S1", tracker=kind, run=0, kind=kind, params=params, seed=SEED, cutoff_m=1000.0,
                            source=GeneratedScenes("S1", "preset S1", preset("S1"))))


@pytest.mark.parametrize("kind", ["gnn", "ekphd"])
def test_track_equals_the_study_job_for_the_same_tracker_and_run(s1, kind):
    record = _job(kind, {})
    run = run_tracker(s1, kind)
    assert scalars(run.scores) == record["metrics"]
    assert run.scores.ownership == record["ownership"]
    # the job keeps run 0's ever-confirmed tracks (x, y by track then scan): the same rows of the table
    t = run.table.to_pydict()
    ids = np.array(t["track_id"])
    keep = np.isin(ids, np.unique(ids[np.array(t["status"]) == "confirmed"]))
    order = np.lexsort((np.array(t["scan"])[keep], ids[keep]))
    for column in ("scan", "track_id", "x", "y"):
        assert np.array(t[column])[keep][order].tolist() == record["tracks"][column]
    assert [TrackStatus[s.upper()] for s in np.array(t["status"])[keep][order]] == record["tracks"]["status"]


def test_a_tracker_runs_once_untimed_before_its_first_job_in_a_process(monkeypatch):
    from nnda.study import track_job as job_module

    built = []
    real = job_module.make_tracker
    monkeypatch.setattr(job_module, "make_tracker", lambda kind, *a: built.append(kind) or real(kind, *a))
    monkeypatch.setattr(job_module, "_WARM", set())
    first = _job("gnn", {})
    assert built == ["gnn", "gnn"]  # the warm-up, then the timed run
    _job("gnn", {})
    assert built == ["gnn", "gnn", "gnn"]  # warm already: the timed run alone
    _job("gnn", {"gate": 6.0})  # other params: another tracker to warm
    assert built == ["gnn", "gnn", "gnn", "gnn", "gnn"]
    monkeypatch.setattr(job_module, "_WARM", set())
    again = _job("gnn", {})
    assert again["metrics"] == first["metrics"] and again["series"] == first["series"]


def test_the_table_holds_state_covariance_and_contacts(s1):
    run = run_tracker(s1, "gnn")
    table = run.table
    assert table.schema == TRACK_SCHEMA and len(COV_COLUMNS) == 10
    out = run.outputs[20]
    rows = table.filter(np.array(table.column("scan")) == out.scan).to_pydict()
    np.testing.assert_array_equal(rows["x"], out.state[:, 0])
    np.testing.assert_array_equal(rows["cov_vx_y"], out.covariance[:, 1, 2])
    np.testing.assert_array_equal(rows["contact"], out.contact)
    used = np.array(rows["detection"])[np.array(rows["contact"]) >= 0]
    b = s1.scan_bounds()
    assert ((used >= b[out.scan - 1]) & (used < b[out.scan])).all()


def test_nnda_track_is_one_call_that_loads_nothing_heavy_before(s1_dir, tmp_path):
    code = "import sys, nnda; print('pyarrow' in sys.modules, 'nnda.tracking' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout.split() == \
        ["False", "False"]
    fs = feature_set("kinematic-3")
    weights = MLPWeights.from_vector(np.random.default_rng(0).normal(0, 0.5, n_weights(fs.size, 3)), fs.size, 3)
    model = save_model(Scorer(weights, Normaliser(np.zeros(fs.size), np.full(fs.size, 10.0)), fs),
                       tmp_path / "m.json")
    table = nnda.track(s1_dir, "nn", model=model)
    assert table.schema == TRACK_SCHEMA and table.num_rows > 0
    assert table.equals(run_tracker(s1_dir, "nn", {"model": str(model)}).table)


def test_the_command_writes_tracks_plots_and_scores_the_same_bytes_twice(s1_dir, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    done = runner.invoke(app, ["track", str(s1_dir), "--tracker", "gnn", "--out", "a"])
    assert done.exit_code == 0, done.output
    assert "GOSPA" in done.output and "wrote a" in done.output
    files = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert files == ["scores.json", "tracks.html", "tracks.parquet", "tracks.png"]
    scores = json.loads((tmp_path / "a" / "scores.json").read_text())
    assert scores["metrics"] == scalars(run_tracker(s1_dir, "gnn").scores)
    again = runner.invoke(app, ["track", str(s1_dir), "--tracker", "gnn", "--out", "a"])
    assert isinstance(again.exception, FileExistsError)
    assert runner.invoke(app, ["track", str(s1_dir), "--tracker", "gnn", "--out", "b", "--quiet"]).exit_code == 0
    for name in files:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_parquet(tmp_path / "a" / "tracks.parquet")
    assert list(frame.columns) == TRACK_SCHEMA.names and frame["scan"].dtype == np.int32
    assert set(frame["status"]) <= {"preliminary", "confirmed", "deleted"}


def test_csv_format_and_a_dataset_without_truth(s1, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    export_detections(s1, tmp_path / "plots.csv")
    import_detections(tmp_path / "plots.csv", tmp_path / "plots", sensors=sensor_specs(s1.scenario))
    done = CliRunner().invoke(app, ["track", "plots", "--tracker", "gnn", "--out", "t", "--format", "csv"])
    assert done.exit_code == 0, done.output
    assert "no truth in the dataset: scores.json records the run, its metrics null" in " ".join(done.output.split())
    assert sorted(p.name for p in (tmp_path / "t").iterdir()) == ["scores.json", "tracks.csv", "tracks.html",
                                                                   "tracks.png"]
    record = json.loads((tmp_path / "t" / "scores.json").read_text())
    assert record["metrics"] is None and record["ownership"] is None
    assert record["detection_probability"] == [{"sensor": "radar", "pd": 0.9, "source": "tracker default"}]
    assert sum(record["track_management"]["deletions"].values()) > 0
    back = pacsv.read_csv(tmp_path / "t" / "tracks.csv")
    want = run_tracker(tmp_path / "plots", "gnn").table
    assert back.column_names == want.column_names and back.num_rows == want.num_rows
    np.testing.assert_array_equal(back.column("cov_x_x").to_numpy(), want.column("cov_x_x").to_numpy())


def test_the_example_nn_life_config_is_life5_and_tracks(s1_dir):
    example = Path(__file__).resolve().parents[2] / "examples" / "nn-life.toml"
    fs = feature_set("imm-innovation-9")
    weights = MLPWeights.from_vector(np.random.default_rng(1).normal(0, 0.5, n_weights(fs.size, 5)), fs.size, 5)
    model = save_model(Scorer(weights, Normaliser(np.zeros(fs.size), np.ones(fs.size)), fs),
                       s1_dir.parent / "ext.json")
    assert tracker_params(example, model) == {"feature_set": "imm-innovation-9", **life5(), "model": str(model)}
    run = run_tracker(s1_dir, "nn", example, model)
    assert run.table.num_rows > 0 and run.scores.values["confirmed_tracks"] > 0
