"""Bad input through the Python API: generator arguments, scenarios, in-memory datasets written to disk,
collections, model files. Each is an NndaError naming what and where, and nothing is written."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from cli_run import TINY

from dataset_edits import snapshot
from nnda.data import generator
from nnda.data.checks import estimate_size
from nnda.data.dataset import read_dataset, write_collection, write_dataset
from nnda.data.generator import check_scenario, generate, generate_runs
from nnda.data.scenario import scenario_from_dict
from nnda.errors import ConfigError, DatasetError, ModelError, OutputError
from nnda.models.scorer import load_model


@pytest.fixture
def tiny():
    return scenario_from_dict(TINY)


def _scenario(**changes):
    data = {**TINY, **changes}
    if "sensors" in changes:
        del data["clutter"]
    return scenario_from_dict(data)


@pytest.mark.parametrize("kwargs, message", [
    ({"seed": -1}, "seed is -1; it must be a whole number >= 0"),
    ({"seed": 1.5}, "seed is 1.5; it must be a whole number >= 0"),
    ({"seed": True}, "seed is True"),
    ({"run": -2}, "run is -2; it must be a whole number >= 0"),
    ({"run": "0"}, "run is '0'"),
    ({"max_detections": 0}, "max_detections is 0; it must be a whole number >= 1"),
    ({"max_detections": 10}, "scenario 'tiny': one dataset would hold up to 18 detections"),
])
def test_generator_arguments(tiny, kwargs, message):
    with pytest.raises(ConfigError, match=message):
        generate(tiny, **kwargs)


def test_a_bad_run_in_a_monte_carlo_set_is_named(tiny):
    runs = generate_runs(tiny, [0, -1])
    assert next(runs).run == 0
    with pytest.raises(ConfigError, match="run is -1"):
        next(runs)


@pytest.mark.parametrize("changes, detections", [
    ({"duration_s": 2e7}, 50_000_004),                                     # 1e7 scans of 5 clutter points
    ({"sensor": {"scan_period_s": 1e-6}, "duration_s": 120}, 606_000_001),  # 1.2e8 scans, the target alive in 6e6
    ({"clutter": {"count": 100_000_000}}, 300_000_003),                      # 1e8 clutter points per sweep
])
def test_oversized_scenarios_fail_before_any_work_that_grows_with_them(changes, detections, monkeypatch):
    """Refused from the scenario's numbers: before the noise-free plan is built (building it fails the test)."""
    big = _scenario(**changes)
    assert estimate_size(big).detections == detections

    def planned(*_):
        raise AssertionError("the plan was built before the size was refused")

    monkeypatch.setattr(generator.Plan, "of", planned)
    with pytest.raises(ConfigError, match=f"up to {detections:,} detections"):
        generate(big)
    with pytest.raises(ConfigError, match="raise the limit with --max-detections"):
        check_scenario(big)


def test_the_estimate_bounds_what_is_generated():
    sc = _scenario(clutter={"count": 7, "count_law": "poisson"}, duration_s=40,
                   targets=[{**TINY["targets"][0], "segments": [{"duration_s": 40}]},
                            {**TINY["targets"][0], "name": "b", "start_time_s": 10, "segments": [{"duration_s": 8}]}])
    size = estimate_size(sc)
    ds = generate(sc, seed=3)
    assert (size.scans, size.truth_rows, size.clutter) == (20, 20 + 5, 140)
    assert ds.truth.scan.size <= size.truth_rows and (~ds.detections.is_clutter).sum() <= size.truth_rows


def test_clutter_outside_the_coverage_names_scenario_and_sensor():
    sc = _scenario(sensors=[{"name": "west", "x_m": -20000.0}, {"name": "east", "x_m": 20000.0, "fov_deg": 20,
                                                                "clutter": {"centre_m": [-20000.0, 0.0]}}])
    for call in (generate, check_scenario):
        with pytest.raises(ConfigError, match=r"scenario 'tiny': clutter of sensor 'east': the square region "
                                              r"\(side 16600 m, centred at \(-20000, 0\) m\) has 0.00%"):
            call(sc)


def test_plausibility_warnings_are_returned_for_any_command(tiny):
    assert check_scenario(tiny) == []
    fast = _scenario(targets=[{**TINY["targets"][0], "speed_m_s": 1500.0}])
    assert check_scenario(fast) == ["scenario 'tiny': target 'a' reaches 1,500 m/s, faster than 1,000 m/s"]
    between = _scenario(targets=[TINY["targets"][0], {**TINY["targets"][0], "name": "blink", "start_time_s": 2.5,
                                                      "segments": [{"duration_s": 1.0}]}])
    assert check_scenario(between) == ["scenario 'tiny': target 'blink' exists at no sweep (2.5-3.5 s falls between "
                                       "sweeps)"]


@pytest.mark.parametrize("name", ["..", ".", ".hidden"])
def test_a_scenario_name_must_be_a_file_name(name):
    with pytest.raises(ConfigError, match=rf"name: Value error, a scenario name: '{name}' cannot name a file"):
        scenario_from_dict({**TINY, "name": name}, "mine.toml")


def _with(ds, record: str, **columns):
    return dataclasses.replace(ds, **{record: dataclasses.replace(getattr(ds, record), **columns)})


def _nan_x(ds):
    x = ds.detections.x.copy()
    x[2] = np.nan
    return _with(ds, "detections", x=x)


@pytest.mark.parametrize("damage, message", [
    (_nan_x, "dataset out: detections: column 'x' has a non-finite value at row 2"),
    (lambda ds: _with(ds, "detections", y=ds.detections.y[:-1]), "dataset out: detections: column 'y' has shape"),
    (lambda ds: _with(ds, "detections", scan=ds.detections.scan.astype(float)),
     "dataset out: detections: column 'scan' has dtype float64, expected int32"),
    (lambda ds: _with(ds, "detections", azimuth=ds.detections.azimuth + 7.0), "column 'azimuth' is .* outside"),
    (lambda ds: _with(ds, "detections", x=ds.detections.x + 1.0), r"columns 'x', 'y' at row 0 .* 1 m from the point"),
    (lambda ds: _with(ds, "truth", time=ds.truth.time * 2), "dataset out: truth: column 'time' is 4.0 s at row 0"),
])
def test_an_implausible_dataset_is_never_written(tmp_path, tiny, damage, message):
    with pytest.raises(DatasetError, match=message):
        write_dataset(damage(generate(tiny)), "out")  # relative: the message names it as given
    assert snapshot(tmp_path) == {}


@pytest.mark.parametrize("names, message", [
    (["../up"], "collection .*mc: member name: '../up' cannot name a file"),
    (["a", "a"], "collection .*mc: member name 'a' is given twice"),
    ([], "collection .*mc: no members to write"),
])
def test_collection_member_names(tmp_path, tiny, names, message):
    ds = generate(tiny)
    with pytest.raises(ConfigError, match=message):
        write_collection(((n, ds) for n in names), tmp_path / "mc", "x")
    assert snapshot(tmp_path) == {}


def test_a_file_is_never_replaced_by_a_dataset(tmp_path, tiny):
    (tmp_path / "out").write_text("mine")
    with pytest.raises(OutputError, match="is a file, not a directory"):
        write_dataset(generate(tiny), tmp_path / "out", overwrite=True)
    assert snapshot(tmp_path) == {"out": b"mine"}


def test_paths_that_are_not_datasets_or_models(tmp_path):
    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(DatasetError, match="f.txt: no such dataset directory"):
        read_dataset(tmp_path / "f.txt")
    with pytest.raises(ModelError, match=r"empty/model.json: no such model file"):
        (tmp_path / "empty").mkdir()
        load_model(tmp_path / "empty")


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


def test_an_imported_scene_gets_a_scenario_name_whatever_its_directory(tmp_path):
    pytest.importorskip("stonesoup")
    from nnda.peers.importer import StoneSoupScene, import_stonesoup

    path = import_stonesoup(tmp_path / ".Ωmega run", StoneSoupScene(n_scans=3, clutter=2.0), seed=1)
    assert read_dataset(path).scenario.name == "__mega_run"
