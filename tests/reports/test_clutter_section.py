"""The report's clutter-density section on a tiny sweep: the sweep is found from the scenarios alone, the
plotted numbers are the summary's, and a study without a sweep has no such section."""

from __future__ import annotations

import json
import math

import pytest

from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.reports.clutter_section import curves, scene_delay_bound, sweeps
from nnda.reports.study_report import build_report
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.tracking.confirmation_bound import clairvoyant_delay_s
from nnda.tracking.lifecycle import LifecycleConfig


def _scene(name: str, count: int, duration: float = 40.0) -> dict:
    sc = PRESETS["S4"].model_copy(update={"duration_s": duration})
    sc = sc.model_copy(update={"clutter": sc.clutter.model_copy(update={"count": count})})
    return {**sc.model_dump(mode="json"), "name": name}


@pytest.fixture(scope="module")
def sweep_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    for name, count in (("S4-c10", 10), ("S4-c200", 200), ("other", 50)):
        (root / f"{name}.json").write_text(json.dumps(_scene(name, count, 40.0 if name != "other" else 20.0)))
    (root / "study.toml").write_text('name = "sweep"\nseed = 1\nruns = 2\n'
                                     '[trackers.gnn]\nkind = "gnn"\n[trackers.ekphd]\nkind = "ekphd"\n'
                                     + "".join(f'[[scenarios]]\nconfig = "{n}.json"\n'
                                               for n in ("S4-c10", "S4-c200", "other")))
    compare(load_study(root / "study.toml"), root / "out", workers=1)
    return root / "out"


def _json(path):
    return json.loads(path.read_text())


def test_the_sweep_is_the_scenes_that_differ_in_clutter_only(sweep_study):
    manifest = _json(sweep_study / "study.json")
    assert sweeps(manifest) == {"S4-c10": {10: "S4-c10", 200: "S4-c200"}}  # "other" is shorter: not in it


def test_the_curves_are_the_summarys_numbers(sweep_study):
    manifest, summary, timing = (_json(sweep_study / f) for f in ("study.json", "summary.json", "timing.json"))
    line = curves(manifest, summary, timing, "gospa")
    by = {s["name"]: s for s in summary["scenarios"]}
    for t in ("gnn", "ekphd"):
        for count, name in ((10, "S4-c10"), (200, "S4-c200")):
            assert line[t][count]["mean"] == by[name]["trackers"][t]["metrics"]["gospa"]["mean"]
    times = curves(manifest, summary, timing, "mean_time_per_scan_s")
    tby = {s["name"]: s for s in timing["scenarios"]}
    assert times["gnn"][200]["mean"] == tby["S4-c200"]["trackers"]["gnn"]["mean_time_per_scan_s"]["mean"]


def test_the_section_draws_and_tabulates_the_sweep(sweep_study):
    md, html, figures = build_report(sweep_study)
    section = md[md.index("## Against clutter density"):]
    section = section[:section.index("\n## ", 5)]
    assert "clutter_sweep.png" in section and "| gnn | 200 |" in section and "| ekphd | 10 |" in section
    assert "is best at 200 clutter per scan" in section
    assert any(f.name == "clutter_sweep.png" and f.png.startswith(b"\x89PNG") for f in figures)


def test_no_section_without_a_sweep(tmp_path):
    (tmp_path / "a.json").write_text(json.dumps(_scene("a", 10, 20.0)))
    (tmp_path / "study.toml").write_text('name = "one"\nruns = 1\n[trackers.gnn]\nkind = "gnn"\n'
                                         '[[scenarios]]\nconfig = "a.json"\n')
    compare(load_study(tmp_path / "study.toml"), tmp_path / "out", workers=1)
    assert "## Against clutter density" not in build_report(tmp_path / "out")[0]


@pytest.mark.parametrize("rule", ["adaptive", "score", "existence"])
def test_the_delay_bound_of_a_scene_is_its_targets(rule):
    """One target 17.5 km north moving east inside a 4 km clutter square wholly in the coverage: the density
    there is the count over the square, and the scene's bound that target's at its first scan (t = 2 s, 200 m
    east); M/N and false tracks at a rate have none, and a tracker without a rule runs the default's."""
    target = Target(name="t", x_m=0.0, y_m=17_500.0, heading_deg=90.0, speed_m_s=100.0,
                    segments=[Segment(duration_s=20.0)])
    sc = Scenario(name="one", duration_s=20.0, targets=[target], seed=3,
                  clutter=Clutter(count=40, side_m=4_000.0, centre_m=(0.0, 17_500.0)))
    dump = sc.model_dump(mode="json")
    params = {"lifecycle": {"confirmation": rule}}
    sensor = sc.sensors[0]
    area = math.pi * (sensor.max_range_m**2 - sensor.min_range_m**2)
    want = clairvoyant_delay_s(rule, LifecycleConfig(confirmation=rule), 40 / 4_000.0**2, math.hypot(200.0, 17_500.0),
                               sensor.sigma_range_m, sensor.sigma_azimuth_rad, sensor.scan_period_s,
                               coverage_m2=area)
    assert scene_delay_bound(dump, params) == pytest.approx(want, rel=1e-9)
    assert scene_delay_bound(dump, {"lifecycle": {"confirmation": "mn"}}) is None
    assert (scene_delay_bound(dump, {}) == scene_delay_bound(dump, {"lifecycle": {"confirmation": "adaptive"}})
            is not None)
    assert scene_delay_bound(dump, {"lifecycle": {"confirmation": "score", "false_tracks_per_scan": 0.01}}) is None
