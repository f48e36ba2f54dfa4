"""The robust-defaults study (studies/robust-defaults.toml) is valid and compares what it says."""

from __future__ import annotations

from pathlib import Path

from nnda.study.config import load_study
from nnda.study.plan import plan_study
from nnda.tracking.registry import check_config, confirmation_rule

STUDY = Path(__file__).resolve().parents[2] / "studies" / "robust-defaults.toml"


def test_defaults_with_a_lag_against_the_thesis_rule_at_two_densities_and_on_manoeuvring_targets():
    """Every tracker's default, and the thesis's M/N rule, on S1-S6 at two densities and on the manoeuvring
    scenes with their radar's P_D undeclared and declared."""
    study = load_study(STUDY)
    plan = plan_study(study)
    rules = {label: confirmation_rule(t.kind, t.params) for label, t in study.trackers.items()}
    assert rules == {k: "adaptive" for k in ("mht", "gnn", "jpda")} | {f"{k}-mn": "mn" for k in ("mht", "gnn", "jpda")}
    assert {label: t.lag for label, t in study.trackers.items()} == {
        k: 3 for k in ("mht", "gnn", "jpda")} | {f"{k}-mn": 0 for k in ("mht", "gnn", "jpda")}
    for label, t in study.trackers.items():  # the defaults are the trackers' own: nothing set but the lag
        assert (t.params == {}) == (not label.endswith("-mn"))
        assert check_config(t.kind, t.params).lifecycle.gate_clutter_bound == (None if label.endswith("-mn") else 2.0)
    scenes = {s.name: s.scenario for s in plan.kinds["track"].scenarios}
    assert set(scenes) == ({f"S{i}-c{c}" for i in range(1, 7) for c in (100, 1_000)}
                           | {f"M{i}{d}" for i in range(1, 7) for d in ("", "-pd")})
    for i in range(1, 7):
        sc = scenes[f"M{i}"]
        sensor = sc.sensors[0]
        noise = (sensor.sigma_range_m, sensor.sigma_azimuth_mrad)
        assert (sensor.pd, sensor.declared_pd, noise, sensor.clutter.count) == (0.8, None, (50.0, 5.0), 300)
        assert 3 <= len(sc.targets) <= 10
        turns = {seg.turn_rate_deg_s for t in sc.targets for seg in t.segments}
        assert turns == {-4.0, 0.0, 4.0}
        declared = scenes[f"M{i}-pd"]  # the same scene, its radar declaring the P_D it has
        assert declared.sensors[0].declared_pd == 0.8
        radar = declared.sensors[0].model_copy(update={"declared_pd": None})
        assert declared.model_copy(update={"name": sc.name, "description": sc.description, "sensors": (radar,)}) == sc
