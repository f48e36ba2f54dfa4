"""A sensor's declared detection probability: the P_D every tracker assumes for its scans unless the tracker
config sets its own, per sensor, imported with ``--sensor pd=X`` and said by ``nnda track``."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

import nnda.tracking.tracker as tracker_module
from nnda.app.cli import app
from nnda.data.dataset import read_dataset
from nnda.data.detections_import import export_detections, import_detections, sensor_specs
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.data.scenario import Sensor, load_scenario
from nnda.errors import ConfigError
from nnda.study.track import detection_record
from nnda.tracking.detection_probability import FROM_CONFIG, FROM_DEFAULT, detection_probabilities
from nnda.tracking.registry import check_config, make_tracker

#: scans of a run: enough for tracks to confirm and clutter to start some
SCANS = 25
#: the trackers whose P_D must follow the declared value (gnn: its score rule's)
TRACKERS = [("gnn", {"lifecycle": {"confirmation": "score"}}), ("jpda", {}), ("mht", {})]


@pytest.fixture(scope="module")
def s1():
    return generate(preset("S1"), seed=3, run=0)


@pytest.fixture(scope="module")
def imported(s1, tmp_path_factory):
    """S1's detections imported twice: with ``pd = 0.6`` given for the sensor, and with no P_D declared."""
    tmp = tmp_path_factory.mktemp("imported")
    export_detections(s1, tmp / "plots.csv", truth=tmp / "truth.csv")
    spec = sensor_specs(s1.scenario)[0]
    declared = {k: v for k, v in spec.items() if k not in ("pd", "declared_pd")} | {"pd": 0.6}
    return tuple(import_detections(tmp / "plots.csv", tmp / out, sensors=[given], truth=tmp / "truth.csv")[1]
                 for out, given in (("declared", declared), ("plain", spec))) + (tmp,)


def _hash(name: str, sensors, params: dict, scans) -> str:
    tracker = make_tracker(name, sensors, params)
    h = []
    for scan in scans:
        o = tracker.step(scan)
        h += [o.track_id.tobytes(), o.status.tobytes(), o.state.tobytes(), o.covariance.tobytes(),
              o.contact.tobytes()]
    return "".join(x.hex() for x in h)


def test_an_import_with_pd_declares_it_and_one_without_keeps_the_manifest_as_before(imported):
    declared, plain, tmp = imported
    assert declared.scenario.sensor.declared_pd == 0.6 and declared.scenario.sensor.pd == 0.6
    assert plain.scenario.sensor.declared_pd is None
    assert json.loads((tmp / "declared" / "scenario.json").read_text())["scenario"]["sensors"][0]["declared_pd"] == 0.6
    assert "declared_pd" not in json.loads((tmp / "plain" / "scenario.json").read_text())["scenario"]["sensors"][0]
    assert read_dataset(tmp / "declared").scenario.sensor.declared_pd == 0.6


def test_a_scenario_file_may_declare_a_pd_for_its_generated_scenes(tmp_path):
    (tmp_path / "scene.toml").write_text(
        'name = "declared"\nduration_s = 20.0\n[[targets]]\nname = "A"\nx_m = 0.0\ny_m = 10000.0\n'
        'heading_deg = 90.0\nspeed_m_s = 150.0\nsegments = [{duration_s = 20.0}]\n'
        '[[sensors]]\npd = 0.8\ndeclared_pd = 0.8\n')
    scenario = load_scenario(tmp_path / "scene.toml")
    assert scenario.sensor.declared_pd == 0.8 and scenario.model_dump()["sensors"][0]["declared_pd"] == 0.8
    assert make_tracker("mht", scenario.sensors).detection.values == (0.8,)
    assert "declared_pd" not in scenario.model_copy(update={"sensors": (Sensor(),)}).model_dump()["sensors"][0]


@pytest.mark.parametrize(("name", "params"), TRACKERS, ids=[t for t, _ in TRACKERS])
def test_the_declared_pd_is_the_trackers_pd(imported, name, params, monkeypatch):
    declared, plain, _ = imported
    scans = list(plain.scans())[:SCANS]
    same = list(declared.scans())[:SCANS]
    assert [s.measurements.tobytes() for s in scans] == [s.measurements.tobytes() for s in same]
    with_declared = _hash(name, declared.scenario.sensors, params, scans)
    assert with_declared != _hash(name, plain.scenario.sensors, params, scans)
    if name == "gnn":  # no pd field: the score rule's P_D is the tracker default, here not learnt
        monkeypatch.setattr(tracker_module, "SCORE_PD", 0.6)
        fixed = params | {"lifecycle": params["lifecycle"] | {"estimate_pd": False}}
        assert _hash(name, plain.scenario.sensors, fixed, scans) == with_declared
    else:
        assert _hash(name, plain.scenario.sensors, params | {"pd": 0.6}, scans) == with_declared


def test_a_pd_set_in_the_tracker_config_beats_the_declared_one(imported):
    declared, plain, _ = imported
    scans = list(plain.scans())[:SCANS]
    set_to_default = _hash("jpda", declared.scenario.sensors, {"pd": 0.9}, scans)
    assert set_to_default == _hash("jpda", plain.scenario.sensors, {"lifecycle": {"estimate_pd": False}}, scans)
    tracker = make_tracker("mht", declared.scenario.sensors, {"pd": 0.8})
    assert tracker.detection.values == (0.8,) and tracker.detection.sources == (FROM_CONFIG,)
    assert make_tracker("mht", declared.scenario.sensors).detection.sources == ("declared by sensor 'radar'",)
    assert make_tracker("mht", plain.scenario.sensors).detection.sources == (FROM_DEFAULT,)


def test_two_sensors_each_with_its_own_declared_pd():
    ds = generate(preset("two-radars"), seed=0, run=0)
    west, east = ds.scenario.sensors

    def declaring(a: float, b: float):
        return (west.model_copy(update={"declared_pd": a}), east.model_copy(update={"declared_pd": b}))

    found = detection_probabilities("jpda", check_config("jpda", {}), declaring(0.6, 0.8))
    assert found.values == (0.6, 0.8)
    assert found.sources == ("declared by sensor 'west'", "declared by sensor 'east'")
    tracker = make_tracker("jpda", declaring(0.6, 0.8))
    used = []
    pd_of = tracker.score_pd
    tracker.score_pd = lambda sensor: used.append((sensor, pd_of(sensor))) or pd_of(sensor)
    scans = list(ds.scans())[:30]
    for scan in scans:
        tracker.step(scan)
    assert {0: 0.6, 1: 0.8} == dict(used) and {s for s, _ in used} == {0, 1}
    both = _hash("jpda", declaring(0.6, 0.8), {}, scans)
    assert both != _hash("jpda", declaring(0.6, 0.6), {}, scans)
    assert both != _hash("jpda", declaring(0.8, 0.8), {}, scans)


@pytest.mark.parametrize("value", ["1.5", "nan"])
def test_an_impossible_pd_at_import_names_the_sensor_and_field(s1, tmp_path, value):
    export_detections(s1, tmp_path / "plots.csv")
    done = CliRunner().invoke(app, ["import-detections", str(tmp_path / "plots.csv"), "--out", str(tmp_path / "d"),
                                    "--sensor", f"pd={value}"])
    assert isinstance(done.exception, ConfigError), done.output  # the CLI's one `error:` line, exit 2
    assert "sensor 0 ('radar')" in str(done.exception) and "- pd: " in str(done.exception)


@pytest.mark.parametrize(("name", "value", "needs"), [("mht", 0.0, "> 0 and < 1"), ("jpda", 0.0, "> 0 and <= 1"),
                                                      ("gnn", 0.0, "> 0 and <= 1"), ("mht", 1.0, "< 1")])
def test_a_declared_pd_the_tracker_cannot_take_is_a_clear_error(s1, name, value, needs):
    sensor = s1.scenario.sensor.model_copy(update={"declared_pd": value, "name": "north"})
    with pytest.raises(ConfigError, match=f"sensor 'north' declares declared_pd = {value:g}.*{needs}.*config's pd"):
        make_tracker(name, sensor)


def test_the_phd_filters_fall_back_on_the_declared_pd_after_sensor_pd_and_pd(s1):
    sensor = s1.scenario.sensor.model_copy(update={"declared_pd": 0.6})
    assert make_tracker("ekphd", sensor).detection.values == (0.6,)
    assert make_tracker("ekphd", sensor, {"pd": 0.7}).detection.values == (0.7,)
    assert make_tracker("ekphd", sensor, {"sensor_pd": [0.8]}).detection.values == (0.8,)
    assert make_tracker("ekphd", s1.scenario.sensor).detection.values == (0.9,)


@pytest.mark.parametrize("name", ["pmbm", "glmb", "lmb"])
def test_the_labelled_trackers_assume_the_declared_pd(imported, name):
    """Their existence updates and births take the declared P_D: the declared data tracks as the undeclared data
    with config ``pd`` 0.6."""
    declared, plain, _ = imported
    assert make_tracker(name, declared.scenario.sensors).detection.values == (0.6,)
    scans = list(declared.scans())[:12]
    assert (_hash(name, declared.scenario.sensors, {}, scans)
            == _hash(name, plain.scenario.sensors, {"pd": 0.6}, scans)
            != _hash(name, plain.scenario.sensors, {}, scans))


def test_the_line_and_record_of_a_run_say_each_sensors_pd_and_its_source(imported):
    declared, plain, _ = imported
    found = detection_record(make_tracker("jpda", declared.scenario.sensors))
    assert found.line() == "P_D: radar 0.6 (declared by sensor 'radar')"
    assert found.record() == [{"sensor": "radar", "pd": 0.6, "source": "declared by sensor 'radar'"}]
    assert detection_record(make_tracker("gnn", plain.scenario.sensors)).line() == "P_D: radar 0.9 (tracker default)"
    assert detection_record(make_tracker("stonesoup-gnn", plain.scenario.sensors)) is None  # it assumes no P_D


@pytest.mark.slow
def test_nnda_track_says_and_records_the_pd_of_each_sensor(imported, tmp_path, monkeypatch):
    _, _, tmp = imported
    monkeypatch.chdir(tmp_path)
    done = CliRunner().invoke(app, ["track", str(tmp / "declared"), "--tracker", "jpda", "--out", "t", "--quiet"])
    assert done.exit_code == 0, done.output
    assert "jpda: P_D: radar 0.6 (declared by sensor 'radar')" in done.output
    scores = json.loads((tmp_path / "t" / "scores.json").read_text())
    assert scores["detection_probability"] == [{"sensor": "radar", "pd": 0.6, "source": "declared by sensor 'radar'"}]
