"""The clutter-sweep study (studies/clutter-sweep.toml) is valid and sweeps what it says."""

from __future__ import annotations

from pathlib import Path

from nnda.data.presets import PRESETS
from nnda.study.config import load_study
from nnda.study.plan import plan_study
from nnda.tracking.registry import confirmation_rule

STUDY = Path(__file__).resolve().parents[2] / "studies" / "clutter-sweep.toml"


def test_the_clutter_sweep_plans_every_preset_at_every_density_under_each_rule():
    study = load_study(STUDY)
    plan = plan_study(study)
    names = {s.name for s in plan.kinds["track"].scenarios}
    assert names == {f"S{i}-c{c}" for i in range(1, 7) for c in (10, 100, 1_000, 5_000)}
    rules = {label: confirmation_rule(t.kind, t.params) for label, t in study.trackers.items()}
    assert sorted(r for r in rules.values() if r) == ["existence"] * 2 + ["mn"] * 3 + ["score"] * 6
    rated = {label for label, t in study.trackers.items()
             if (t.params.get("lifecycle") or {}).get("false_tracks_per_scan") is not None}
    assert rated == {"gnn-rate", "jpda-rate", "mht-rate"}  # the score rule with false tracks at a rate
    assert {label for label, r in rules.items() if r is None} == {"ekphd", "cphd", "ekphd-k3", "cphd-k3"}  # extraction
    for s in plan.kinds["track"].scenarios:
        preset, count = s.name.split("-c")
        sc = s.scenario
        assert sc.clutter.count == int(count)
        same = PRESETS[preset].model_copy(update={"clutter": sc.clutter, "name": sc.name,
                                                  "description": sc.description})
        assert sc == same
