"""`nnda.study.tuning`: the search space, the split, the objectives with and without truth, and bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from tests.conftest import straight_target

from nnda import extras
from nnda.data.dataset import Truth
from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment
from nnda.errors import ConfigError, NndaError
from nnda.filters.imm import IMM
from nnda.filters.measurement import measurement_model
from nnda.study import tuning
from nnda.study.track import run_tracker
from nnda.study.tuning import MIN_WINDOW_SCANS, NO_UPDATES, scan_window, split_scans, tune
from nnda.study.tuning_space import CANDIDATES, Dimension, search_space, with_values
from nnda.tracking.registry import check_config, make_tracker
from nnda.tracking.tracker import MotionConfig

#: far faster than the default initiation window's v_max (200 m/s): the default config starts no track
FAST_M_S = 320.0


def fast_scene() -> Scenario:
    """Three straight 320 m/s targets, 40 scans of 2 s, light clutter."""
    targets = [straight_target("A", speed_m_s=FAST_M_S, segments=[Segment(duration_s=80.0)]),
               straight_target("B", x_m=8_000.0, y_m=-12_000.0, heading_deg=330.0, speed_m_s=FAST_M_S,
                               segments=[Segment(duration_s=80.0)]),
               straight_target("C", x_m=-15_000.0, y_m=-5_000.0, heading_deg=45.0, speed_m_s=FAST_M_S,
                               segments=[Segment(duration_s=80.0)])]
    return Scenario(name="fast", duration_s=80.0, seed=5, targets=targets, clutter=Clutter(count=20))


@pytest.fixture(scope="module")
def fast():
    return generate(fast_scene(), 5)


def without_truth(dataset):
    empty = Truth(*(np.asarray(getattr(dataset.truth, f.name))[:0] for f in dataclasses.fields(Truth)))
    return dataclasses.replace(dataset, truth=empty)


def test_the_default_motion_config_is_the_imm_every_tracker_ran():
    for sensor in fast_scene().sensors:
        assert MotionConfig().imm(measurement_model(sensor)) == IMM.for_sensor(sensor)


def test_the_motion_field_reaches_the_trackers_filter(fast):
    tracker = make_tracker("gnn", fast.scenario.sensors, {"motion": {"cv_sigma_q": 9.0, "p_cv_to_ct": 0.2}})
    assert tracker.filter.models[0].sigma_q == 9.0
    assert tracker.filter.tpm[0] == pytest.approx((0.8, 0.2))


def test_the_space_follows_the_config_fields_not_the_tracker_name():
    gnn = {d.path for d in search_space(check_config("gnn", {}))}
    assert {"motion.cv_sigma_q", "gate", "lifecycle.v_max", "lifecycle.false_track_rate"} <= gnn
    assert "lifecycle.m" not in gnn  # the adaptive rule has no M/N counts
    mn = {d.path for d in search_space(check_config("gnn", {"lifecycle": {"confirmation": "mn"}}))}
    assert {"lifecycle.m", "lifecycle.n", "lifecycle.max_misses"} <= mn
    phd = {d.path for d in search_space(check_config("gmphd", {}))}
    assert {"sigma_q", "pd", "birth.rate"} <= phd and not any(p.startswith("motion.") for p in phd)
    assert "clutter" not in phd  # "local": a rule, not a number
    assert "clutter" in {d.path for d in search_space(check_config("gmphd", {"clutter": 5.0}))}


def test_a_range_widens_to_hold_the_base_and_the_report_gap_is_searched_on_reports_only():
    ships = check_config("gnn", {"lifecycle": {"v_min": 0.0, "v_max": 20.0, "max_misses": 12, "confirmation": "mn"}})
    space = {d.path: d for d in search_space(ships)}
    assert (space["lifecycle.v_max"].low, space["lifecycle.v_max"].high) == (5.0, 800.0)  # not 100 m/s and up
    assert (space["lifecycle.max_misses"].low, space["lifecycle.max_misses"].high) == (1, 48)
    assert space["motion.cv_sigma_q"] == next(d for d in CANDIDATES if d.path == "motion.cv_sigma_q")  # held: kept
    assert "lifecycle.report_gap_s" not in space
    assert "lifecycle.report_gap_s" in {d.path for d in search_space(ships, reports=True)}


def test_with_values_sets_nested_paths_and_keeps_the_base():
    base = {"lifecycle": {"m": 2}, "gate": 9.0}
    out = with_values(base, {"lifecycle.v_max": 300.0, "motion.cv_sigma_q": 2.0})
    assert out == {"lifecycle": {"m": 2, "v_max": 300.0}, "gate": 9.0, "motion": {"cv_sigma_q": 2.0}}
    assert base == {"lifecycle": {"m": 2}, "gate": 9.0}


def test_a_scan_window_runs_and_scores_like_a_dataset(fast):
    w = scan_window(fast, 21, 40)
    assert w.n_scans == 20 and w.scan_time[0] == fast.scan_time[20]
    assert w.detections.scan.min() == 1 and w.truth.scan.max() == 20
    assert len(list(w.scans())) == 20
    assert run_tracker(w, "gnn", {"lifecycle": {"v_max": 400.0}}).scores.values["gospa"] >= 0


def test_tuning_on_the_first_half_beats_the_default_on_the_held_out_half(fast):
    result = tune(fast, "gnn", trials=8, seed=0)
    default, tuned = result.scores[("default", "held-out")], result.scores[("tuned", "held-out")]
    assert default["hit_rate"] == 0  # the default window (v_max 200 m/s) starts no track of a 320 m/s target
    assert tuned["gospa"] < 0.8 * default["gospa"]
    assert result.best_values["lifecycle.v_max"] > FAST_M_S
    assert result.trials[0].params["lifecycle.v_max"] == 200.0  # the first trial is the default
    assert result.scores[("tuned", "tuning")]["gospa"] <= result.scores[("default", "tuning")]["gospa"]


def test_the_same_seed_gives_the_same_search(fast):
    a, b = (tune(fast, "gnn", trials=4, seed=3) for _ in range(2))
    assert a.trials == b.trials and a.best_params == b.best_params and a.scores == b.scores


def test_without_truth_the_objective_runs_and_the_tuned_config_is_valid(fast):
    result = tune(without_truth(fast), "gnn", {"lifecycle": {"v_max": 400.0}}, trials=4, seed=0)
    assert not result.truth
    scores = result.scores[("tuned", "tuning")]
    assert scores["updates"] > 0 and 0 < scores["objective"] < NO_UPDATES
    assert scores["objective"] <= result.scores[("default", "tuning")]["objective"]
    check_config("gnn", result.best_params)


def test_without_truth_a_tracker_without_contacts_or_filters_is_refused(fast):
    with pytest.raises(ConfigError, match="without truth.*tune it on a dataset with truth"):
        tune(without_truth(fast), "gmphd", trials=1)


def test_an_inconsistent_trial_is_pruned_not_fatal(fast, monkeypatch):
    # a window whose ends overlap: the trials with v_min >= v_max are refused by the config and pruned
    space = (Dimension("lifecycle.v_min", 150.0, 400.0), Dimension("lifecycle.v_max", 210.0, 500.0))
    monkeypatch.setattr(tuning, "search_space", lambda config, reports=False: space)
    result = tune(fast, "gnn", trials=8, seed=0)
    pruned = [t for t in result.trials if t.state == "PRUNED"]
    assert pruned and all(t.params["lifecycle.v_min"] >= t.params["lifecycle.v_max"] for t in pruned)
    assert all(t.objective is None for t in pruned)
    assert result.best_values["lifecycle.v_min"] < result.best_values["lifecycle.v_max"]


def test_a_kept_field_stays_at_the_base_value_in_every_trial(fast):
    base = {"lifecycle": {"confirmation": "mn", "max_misses": 4}}  # M/N: its max_misses is searched
    result = tune(fast, "gnn", base, trials=5, seed=0, keep=["lifecycle.max_misses"])
    assert result.kept == ("lifecycle.max_misses",)
    assert "lifecycle.max_misses" not in {d.path for d in result.space}
    assert all("lifecycle.max_misses" not in t.params for t in result.trials)
    assert result.best_params["lifecycle"]["max_misses"] == 4
    free = tune(fast, "gnn", base, trials=1, seed=0)
    assert "lifecycle.max_misses" in {d.path for d in free.space}


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"keep": ["lifecycle.max_miss"]}, "--keep lifecycle.max_miss: not among the fields this search tunes; "
                                       "choose from motion.cv_sigma_q"),
    ({"trials": 0}, "--trials 0: give a whole number of trials, 1 or more"),
    ({"fraction": 1.5}, "--fraction 1.5: the share of the scans tuned on must lie strictly between 0 and 1"),
    ({"fraction": 0.05}, f"each part needs {MIN_WINDOW_SCANS} at least"),
    ({"tracker": "kalman"}, "kalman"),
    ({"params": {"n_scan": 3}}, "n_scan.*options of tracker.*mht"),
])
def test_bad_input_is_one_clear_error(fast, kwargs, message):
    args = {"tracker": "gnn", **kwargs}
    with pytest.raises(ConfigError, match=message):
        tune(fast, args.pop("tracker"), **args)


def test_split_scans_takes_the_floor_of_the_fraction():
    assert split_scans(100, 0.5) == 50 and split_scans(41, 0.5) == 20


def test_optuna_missing_is_one_clear_error(fast, monkeypatch):
    def missing(module, purpose):
        raise NndaError(f"{purpose} needs {module}, which is not installed here: pip install \"nnda[tune]\"")

    monkeypatch.setattr(extras, "require", missing)
    with pytest.raises(NndaError, match=r"nnda tune needs optuna.*nnda\[tune\]"):
        tune(fast, "gnn", trials=1)


def test_a_switching_penalty_charges_the_track_switches_in_the_objective(fast):
    """With gamma > 0 the objective is the mean GOSPA with that switching penalty, at least the GOSPA and above
    it where tracks switch; gamma = 0 is the plain GOSPA search, trial by trial."""
    plain, zero = tune(fast, "gnn", trials=4, seed=3), tune(fast, "gnn", trials=4, seed=3, switching_penalty_m=0.0)
    assert zero.trials == plain.trials and zero.scores == plain.scores and zero.measures == tuning.MEASURES
    charged = tune(fast, "gnn", trials=4, seed=3, switching_penalty_m=1000.0)
    assert charged.switching_penalty_m == 1000.0 and charged.measures == tuning.SWITCHING_MEASURES
    for part in charged.scores.values():
        assert part["gospa_switching"] >= part["gospa"]
        assert (part["gospa_switching"] > part["gospa"]) == (part["track_switches"] > 0)
    assert any(s["track_switches"] > 0 for s in charged.scores.values())
    objectives = [(a.objective, b.objective) for a, b in zip(plain.trials, charged.trials)]
    assert objectives[0][1] >= objectives[0][0] and any(b > a for a, b in objectives if a is not None)


@pytest.mark.parametrize("gamma", [-1.0, float("nan"), float("inf"), True, "100"])
def test_a_bad_switching_penalty_is_one_clear_error(fast, gamma):
    with pytest.raises(ConfigError, match=r"--switching-penalty .*: must be a number of metres >= 0"):
        tune(fast, "gnn", trials=1, switching_penalty_m=gamma)


def test_a_switching_penalty_without_truth_is_refused(fast):
    with pytest.raises(ConfigError, match="--switching-penalty 500: .*needs truth.*leave the option out"):
        tune(without_truth(fast), "gnn", trials=1, switching_penalty_m=500.0)
    with pytest.raises(ConfigError, match="--switching-penalty 500"):
        tuning.search([without_truth(fast)], "gnn", trials=1, switching_penalty_m=500.0)
