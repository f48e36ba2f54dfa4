"""A sensor's declared class of target (ships, aircraft, pedestrians): the speed window and motion noise every
contact tracker takes for the fields its config leaves out, imported with ``--sensor targets=...`` and said by
``nnda track``."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

import nnda
from nnda.app.cli import app
from nnda.data.dataset import read_dataset
from nnda.data.detections_import import export_detections
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.data.scenario import TARGET_CLASSES, load_scenario
from nnda.errors import BoundWarning, ConfigError
from nnda.study.track import run_tracker, targets_record
from nnda.tracking.gnn import GNNConfig, GNNTracker
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.output import CONFIRMED
from nnda.tracking.registry import make_tracker
from nnda.tracking.target_classes import CLASS_DEFAULTS

#: the contact trackers (the neural tracker needs a trained model; it shares their base)
CONTACT_TRACKERS = ("gnn", "jpda", "mht", "pmbm", "glmb", "lmb")


def _fast_scene(tmp_path, declared: str | None):
    """One airliner at 250 m/s in the view of a clutter-free radar sweeping every 10 s, for 180 s (18 sweeps),
    its sensor declaring ``declared`` (or nothing)."""
    line = "" if declared is None else f'declared_targets = "{declared}"\n'
    (tmp_path / "fast.toml").write_text(
        'name = "fast"\nduration_s = 180.0\n[[targets]]\nname = "A"\nx_m = -22000.0\ny_m = 12000.0\n'
        'heading_deg = 90.0\nspeed_m_s = 250.0\nsegments = [{duration_s = 180.0}]\n'
        f'[[sensors]]\npd = 1.0\nscan_period_s = 10.0\n{line}clutter = {{law = "none"}}\n')
    return load_scenario(tmp_path / "fast.toml")


def _confirmed(name: str, scenario, params: dict | None = None) -> int:
    tracker = make_tracker(name, scenario.sensors, params)
    return sum(int((tracker.step(s).status == CONFIRMED).sum()) for s in generate(scenario, seed=0).scans())


def _sensor(declared: str, name: str = "radar"):
    return preset("S1").sensor.model_copy(update={"declared_targets": declared, "name": name})


def test_the_table_covers_every_class_and_each_is_a_valid_config():
    assert tuple(CLASS_DEFAULTS) == TARGET_CLASSES == ("ships", "aircraft", "pedestrians")
    for name in TARGET_CLASSES:
        cfg = make_tracker("gnn", _sensor(name)).config
        for section, values in CLASS_DEFAULTS[name].items():
            assert {k: getattr(getattr(cfg, section), k) for k in values} == values


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_a_250_m_s_target_is_confirmed_with_the_aircraft_class_and_not_without(tmp_path, name):
    with pytest.warns(BoundWarning, match="lifecycle.v_max = 200 m/s"):  # the default window stops at 200 m/s
        assert _confirmed(name, _fast_scene(tmp_path, None)) == 0
    assert _confirmed(name, _fast_scene(tmp_path, "aircraft")) >= 10


@pytest.mark.parametrize("name", CONTACT_TRACKERS)
def test_every_contact_tracker_takes_the_class(name):
    tracker = make_tracker(name, _sensor("ships"))
    life, motion = tracker.config.lifecycle, tracker.config.motion
    assert (life.v_min, life.v_max, life.speed_limit, life.report_gap_s) == (0.0, 20.0, 50.0, 400.0)
    assert (motion.cv_sigma_q, motion.ct_sigma_q, motion.ct_sigma_omega) == (0.2, 0.2, 0.001)
    assert tracker.filter.models[0].sigma_q == 0.2 and tracker.targets.name == "ships"


def test_a_field_the_config_sets_wins_per_field_nested():
    tracker = make_tracker("gnn", _sensor("ships"), {"lifecycle": {"v_max": 15.0, "confirmation": "mn"},
                                                      "motion": {"noise": "continuous"}})
    life = tracker.config.lifecycle
    assert (life.v_min, life.v_max, life.speed_limit, life.confirmation) == (0.0, 15.0, 50.0, "mn")
    assert tracker.config.motion.noise == "continuous" and tracker.config.motion.cv_sigma_q == 0.2
    assert tracker.targets.from_config == ("lifecycle.v_max",) and "lifecycle.v_max" not in tracker.targets.applied
    # a config object given to the class itself: the same resolution, from its fields set
    built = GNNTracker(_sensor("aircraft"), GNNConfig(lifecycle=LifecycleConfig(v_max=400.0)))
    assert (built.config.lifecycle.v_min, built.config.lifecycle.v_max) == (50.0, 400.0)
    assert built.targets.from_config == ("lifecycle.v_max",)
    # a user's v_max of 15 is refused with the default v_min 70, and fine with the ships' 0
    with pytest.raises(ConfigError, match="v_min must be below v_max"):
        make_tracker("gnn", preset("S1").sensor, {"lifecycle": {"v_max": 15.0}})


def test_the_pd_resolution_is_kept_under_a_class():
    sensor = _sensor("aircraft").model_copy(update={"declared_pd": 0.6})
    assert make_tracker("jpda", sensor).detection.values == (0.6,)
    assert make_tracker("jpda", sensor, {"pd": 0.8}).detection.values == (0.8,)


def test_sensors_declaring_different_classes_are_refused():
    with pytest.raises(ConfigError, match=r"sensor 'radar' aircraft, sensor 'ais' ships.*one speed window"):
        make_tracker("gnn", (_sensor("aircraft"), _sensor("ships", "ais").model_copy(update={"x_m": 1.0})))
    # a sensor declaring none takes the class of the one that does
    tracker = make_tracker("gnn", (_sensor("aircraft"), preset("S1").sensor.model_copy(update={"name": "b"})))
    assert tracker.config.lifecycle.v_max == 300.0 and tracker.targets.sensors == ("radar",)


@pytest.mark.parametrize(("params", "said"), [
    ({"lifecycle": {"v_max": 30.0}}, r"lifecycle.v_max = 30\).*'aircraft'.*sensor 'radar'.*lifecycle.v_min = 50"),
    ({"lifecycle": {"max_speed_m_s": 250.0}}, r"lifecycle.max_speed_m_s = 250\).*'aircraft'.*v_max = 300"),
])
def test_an_impossible_mix_names_the_field_the_class_and_the_sensor(params, said):
    with pytest.raises(ConfigError, match=said):
        make_tracker("gnn", _sensor("aircraft"), params)


def test_an_impossible_mix_from_a_config_object_is_refused_alike():
    """A max_speed_m_s of 250 goes with the default v_max 200, not with the aircraft's 300."""
    with pytest.raises(ConfigError, match=r"max_speed_m_s = 250\).*'aircraft'.*sensor 'radar'.*v_max = 300"):
        GNNTracker(_sensor("aircraft"), GNNConfig(lifecycle=LifecycleConfig(max_speed_m_s=250.0)))


def test_the_user_v_max_100_goes_with_the_aircraft_class():
    life = make_tracker("gnn", _sensor("aircraft"), {"lifecycle": {"v_max": 100.0}}).config.lifecycle
    assert (life.v_min, life.v_max) == (50.0, 100.0)


def test_nothing_declared_keeps_the_config_and_the_dump():
    sensor = preset("S1").sensor
    config = GNNConfig()
    tracker = GNNTracker(sensor, config)
    assert tracker.config is config and tracker.targets is None and targets_record(tracker) is None
    assert "declared_targets" not in sensor.model_dump() and "declared_targets" not in sensor.model_dump_json()
    assert _sensor("ships").model_dump()["declared_targets"] == "ships"


@pytest.fixture(scope="module")
def plots(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plots")
    export_detections(generate(preset("S1"), seed=3, run=0), tmp / "plots.csv", truth=tmp / "truth.csv")
    return tmp


def _import(plots, out, *given):
    return CliRunner().invoke(app, ["import-detections", str(plots / "plots.csv"), "--truth", str(plots / "truth.csv"),
                                    "--out", str(out), *[x for g in given for x in ("--sensor", g)]])


@pytest.mark.parametrize("value", ["boats", "Aircraft"])
def test_an_unknown_class_at_import_lists_the_classes(plots, tmp_path, value):
    done = _import(plots, tmp_path / "d", f"targets={value}")
    assert isinstance(done.exception, ConfigError), done.output
    assert (f"sensor 0 ('radar'): targets = {value!r} is no target class nnda knows; choose one of ships, "
            f"aircraft, pedestrians") in str(done.exception)


def test_the_import_declares_the_class_and_the_run_says_and_records_it(plots, tmp_path):
    done = _import(plots, tmp_path / "d", "targets=aircraft")
    assert done.exit_code == 0, done.output
    assert "watches aircraft" in done.output
    manifest = json.loads((tmp_path / "d" / "scenario.json").read_text())["scenario"]["sensors"][0]
    assert manifest["declared_targets"] == "aircraft"
    run = run_tracker(tmp_path / "d", "gnn")
    assert run.targets.line() == ("targets: aircraft (declared by sensor 'radar'): v 50-300 m/s, deleted above "
                                  "750 m/s, cv_sigma_q 3.5 m/s^2, ct_sigma_q 5 m/s^2, ct_sigma_omega 0.044 rad/s")
    assert run.targets.record() == {
        "class": "aircraft", "sensors": ["radar"], "v_min_m_s": 50.0, "v_max_m_s": 300.0, "max_speed_m_s": 750.0,
        "applied": {"lifecycle.v_min": 50.0, "lifecycle.v_max": 300.0, "lifecycle.max_speed_m_s": 750.0,
                    "motion.cv_sigma_q": 3.5, "motion.ct_sigma_q": 5.0, "motion.ct_sigma_omega": 0.044},
        "from_config": []}
    plain = _import(plots, tmp_path / "p")
    assert plain.exit_code == 0 and "declared_targets" not in (tmp_path / "p" / "scenario.json").read_text()


def test_a_sensors_file_declares_the_class_too_and_two_names_must_agree(plots, tmp_path):
    (tmp_path / "s.toml").write_text('[[sensors]]\nname = "radar"\ntargets = "pedestrians"\n')
    done = CliRunner().invoke(app, ["import-detections", str(plots / "plots.csv"), "--out", str(tmp_path / "d"),
                                    "--sensors", str(tmp_path / "s.toml")])
    assert done.exit_code == 0, done.output
    assert '"declared_targets": "pedestrians"' in (tmp_path / "d" / "scenario.json").read_text()
    done = _import(plots, tmp_path / "e", "targets=ships", "declared_targets=aircraft")
    assert isinstance(done.exception, ConfigError)
    assert "targets = 'ships' and declared_targets = 'aircraft' disagree" in str(done.exception)


def test_nnda_track_says_and_records_the_class(plots, tmp_path, monkeypatch):
    assert _import(plots, tmp_path / "d", "targets=ships").exit_code == 0
    monkeypatch.chdir(tmp_path)
    done = CliRunner().invoke(app, ["track", str(tmp_path / "d"), "--tracker", "gnn", "--out", "t", "--quiet",
                                    "--config", str(_config(tmp_path))])
    assert done.exit_code == 0, done.output
    assert "gnn: targets: ships (declared by sensor 'radar'): v 0-25 m/s" in " ".join(done.output.split())
    scores = json.loads((tmp_path / "t" / "scores.json").read_text())
    assert scores["target_class"]["class"] == "ships" and scores["target_class"]["from_config"] == ["lifecycle.v_max"]


def test_the_python_api_checks_a_config_with_the_class_its_dataset_declares(plots, tmp_path):
    """``nnda.track``'s up-front check of the config: v_max 25 goes with the ships' v_min 0."""
    assert _import(plots, tmp_path / "d", "targets=ships").exit_code == 0
    table = nnda.track(tmp_path / "d", "gnn", {"lifecycle": {"v_max": 25.0}})
    assert table.num_rows > 0


def test_tuning_starts_from_the_class_values(plots, tmp_path):
    """``nnda tune``'s first trial is the base config as a run takes it: the ships' window and noise, the
    config's own v_max (refused without the class: v_min 70 > 15)."""
    from nnda.study.tuning import search

    assert _import(plots, tmp_path / "d", "targets=ships").exit_code == 0
    first = search([read_dataset(tmp_path / "d")], "gnn", {"lifecycle": {"v_max": 15.0}}, trials=1).trials[0]
    assert first.state == "COMPLETE", first
    assert (first.params["lifecycle.v_min"], first.params["lifecycle.v_max"]) == (0.0, 15.0)
    assert first.params["motion.cv_sigma_q"] == 0.2


def _config(tmp_path):
    (tmp_path / "c.toml").write_text("[lifecycle]\nv_max = 25.0\n")
    return tmp_path / "c.toml"
