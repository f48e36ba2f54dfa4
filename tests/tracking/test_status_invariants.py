"""Invariants of every registered tracker's output stream, on small drawn scenes and on dense clutter:

* a track id's reported status never goes back from CONFIRMED to PRELIMINARY;
* an id is never reported again after it was reported DELETED;
* the ids of one output are unique.

Every built-in tracker runs (the neural one with a small trained model), the contact trackers under every
confirmation rule they accept, and the Stone Soup peers where Stone Soup is installed. The scenes are drawn by
hypothesis (targets, clutter count, detection probability, seed; derandomized) and short; the dense-clutter
scenes are the clutter sweep's presets at 1,000 clutter points a scan, where MHT's global hypothesis once
reported a confirmed track family by one of its branches that was still preliminary."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import get_args

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import nnda
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import BoundWarning
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import PEERS, TRACKERS, make_tracker
from nnda.tracking.single_hypothesis import SingleHypothesisConfig
from nnda.tracking.tracker import ContactTracker

#: every confirmation rule of the life cycle
RULES = get_args(LifecycleConfig.model_fields["confirmation"].annotation)
#: (tracker, rule) pairs a tracker's config refuses by design
REFUSED = {("mht", "existence")}
#: (tracker, confirmation rule or None: a tracker without one, run with its defaults)
CONTACT_CASES = [(name, rule) for name in TRACKERS if issubclass(TRACKERS[name], ContactTracker)
                 for rule in RULES if (name, rule) not in REFUSED]
#: a tracker that confirms by its own posterior whatever the rule (`ContactTracker.own_confirmation`) runs once,
#: with its defaults: under the other rules it would repeat the same run
CASES = [(name, rule) for name, rule in CONTACT_CASES if TRACKERS[name].own_confirmation is None]
CASES += [(name, None) for name in [*TRACKERS, *PEERS]
          if name in PEERS or not issubclass(TRACKERS[name], ContactTracker)
          or TRACKERS[name].own_confirmation is not None]
IDS = [name if rule is None else f"{name}-{rule}" for name, rule in CASES]
#: the cases of nnda's own trackers (not the peers)
OWN_CASES = [(name, rule) for name, rule in CASES if name not in PEERS]
OWN_IDS = [i for i, (name, _) in zip(IDS, CASES) if name not in PEERS]

#: the clutter sweep's scenes (a preset with 10 times its clutter, and more)
CLUTTER_SWEEP = Path(nnda.__file__).parent / "studies" / "clutter-sweep"

DRAWN = settings(max_examples=8, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def broken(outs) -> list[str]:
    """What breaks the invariants in a run's outputs, one line per case (empty: none)."""
    last, deleted, found = {}, set(), []
    for out in outs:
        ids, status = out.track_id.tolist(), out.status.tolist()
        repeated = sorted({i for i in ids if ids.count(i) > 1})
        if repeated:
            found.append(f"scan {out.scan}: ids {repeated} reported more than once")
        for i, s in zip(ids, status):
            if i in deleted:
                found.append(f"scan {out.scan}: id {i} reported ({TrackStatus(s).name}) after it was deleted")
            if s == TrackStatus.PRELIMINARY and last.get(i) == TrackStatus.CONFIRMED:
                found.append(f"scan {out.scan}: id {i} went back from CONFIRMED to PRELIMINARY")
            if s == TrackStatus.DELETED:
                deleted.add(i)
            last[i] = max(last.get(i, s), s)
    return found


def tracker_for(request, name: str, rule: str | None, sensors, **extra):
    """Tracker ``name`` for ``sensors`` with the config fields ``extra``, under confirmation ``rule`` (None: the
    config's own); the neural tracker with the small trained model of the ``model_file`` fixture."""
    if name in PEERS:
        pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    params = dict(extra)
    if rule is not None:
        params["lifecycle"] = {**params.get("lifecycle", {}), "confirmation": rule}
    if name == "nn":
        params["model"] = str(request.getfixturevalue("model_file"))
    return make_tracker(name, sensors, params)


def for_peers(name: str, scene: Scenario) -> Scenario:
    """``scene`` with at most 20 clutter points a scan for a Stone Soup peer (slow in clutter: ~50 s for eight
    scans of 300), as it is for the other trackers."""
    if name not in PEERS or scene.sensors[0].clutter.count <= 20:
        return scene
    sensor = scene.sensors[0].model_copy(update={"clutter": Clutter(count=20)})
    return scene.model_copy(update={"sensors": (sensor,)})


def outputs(tracker, scans) -> list:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BoundWarning)  # a bound that bites must keep the invariants too
        return [tracker.step(scan) for scan in scans]


@st.composite
def scenes(draw) -> Scenario:
    """One to three targets (some turning) inside the radar's coverage, 6-14 scans, clutter and P_D drawn."""
    n_scans = draw(st.integers(6, 14))
    duration = 2.0 * n_scans
    targets = []
    for k in range(draw(st.integers(1, 3))):
        r, az = draw(st.floats(9_000.0, 24_000.0)), draw(st.floats(0.0, 2 * math.pi))
        turn = draw(st.sampled_from([None, None, -6.0, 4.0]))
        segments = ([Segment(duration_s=duration)] if turn is None else
                    [Segment(duration_s=duration / 2), Segment(duration_s=duration / 2, normal_accel=turn)])
        targets.append(Target(name=f"T{k}", x_m=r * math.sin(az), y_m=r * math.cos(az),
                              heading_deg=draw(st.floats(0.0, 360.0)), speed_m_s=draw(st.floats(70.0, 200.0)),
                              segments=segments))
    sensor = Sensor(pd=draw(st.sampled_from([0.6, 0.8, 0.9, 1.0])),
                    clutter=Clutter(count=draw(st.sampled_from([0, 20, 100, 300]))))
    return Scenario(name="drawn", duration_s=duration, targets=targets, sensors=(sensor,),
                    seed=draw(st.integers(0, 2**16)))


def sweep_scene(name: str) -> Scenario:
    return Scenario.model_validate_json((CLUTTER_SWEEP / f"{name}.json").read_text())


@pytest.mark.parametrize("name, rule", OWN_CASES, ids=OWN_IDS)
@settings(DRAWN)
@given(scene=scenes())
def test_drawn_scenes_keep_the_status_invariants(name, rule, scene, request):
    ds = generate(scene)
    outs = outputs(tracker_for(request, name, rule, scene.sensors), ds.scans())
    assert not broken(outs), broken(outs)


#: the contact trackers of the life cycle's output rule ``report_existence`` (the labelled ones have their own)
HIDING = [name for name in TRACKERS if issubclass(TRACKERS[name], ContactTracker)
          and TRACKERS[name].own_confirmation is None]


@pytest.mark.parametrize("name", HIDING)
@settings(DRAWN)
@given(scene=scenes())
def test_drawn_scenes_keep_the_status_invariants_with_tracks_left_out(name, scene, request):
    """``lifecycle.report_existence`` 0.7 (a confirmed track left out after two misses in a row at P_D 0.9):
    a track left out and reported again is still confirmed, and one deleted while left out is reported deleted
    once and never again."""
    ds = generate(scene)
    outs = outputs(tracker_for(request, name, None, scene.sensors, lifecycle={"report_existence": 0.7}), ds.scans())
    assert not broken(outs), broken(outs)


#: the trackers of track continuation (``continuation_gate``, `nnda.tracking.single_hypothesis.SingleHypothesisConfig`)
CONTINUING = [name for name in TRACKERS if issubclass(TRACKERS[name].config_type, SingleHypothesisConfig)]


@pytest.mark.parametrize("name", CONTINUING)
@settings(DRAWN)
@given(scene=scenes(), hide=st.booleans())
def test_drawn_scenes_keep_the_status_invariants_with_track_continuation(name, scene, hide, request):
    """A wide continuation gate (chi-square 60 on 4 dof), with tracks left out or not: a new track that continues
    an old one is reported deleted without ever being confirmed, and the old one stays confirmed."""
    ds = generate(scene)
    lifecycle = {"report_existence": 0.7} if hide else {}
    tracker = tracker_for(request, name, None, scene.sensors, continuation_gate=60.0, lifecycle=lifecycle)
    outs = outputs(tracker, ds.scans())
    assert not broken(outs), broken(outs)


@pytest.mark.parametrize("name", PEERS)
@settings(DRAWN, max_examples=3)
@given(scene=scenes())
def test_the_peers_keep_the_status_invariants_on_drawn_scenes(name, scene, request):
    ds = generate(for_peers(name, scene))
    outs = outputs(tracker_for(request, name, None, scene.sensors), ds.scans())
    assert not broken(outs), broken(outs)


@pytest.mark.slow
@pytest.mark.parametrize("name, rule", CASES, ids=IDS)
@settings(DRAWN, max_examples=40)
@given(scene=scenes())
def test_many_drawn_scenes_keep_the_status_invariants(name, rule, scene, request):
    ds = generate(for_peers(name, scene))
    outs = outputs(tracker_for(request, name, rule, scene.sensors), ds.scans())
    assert not broken(outs), broken(outs)


@pytest.mark.parametrize("scene, seed, n_scans, lifecycle", [
    ("S6-c1000", 1, 7, {"confirmation": "score", "false_confirmation": 1e-3}),
    ("S4-c1000", 1, 11, {"confirmation": "score", "false_confirmation": 1e-3}),
    ("S3-c1000", 1, 9, {"confirmation": "score"}),
])
def test_a_confirmed_mht_family_stays_confirmed_in_dense_clutter(scene, seed, n_scans, lifecycle, request):
    """At ten times the presets' clutter the global hypothesis gives the contacts of a confirmed family's best
    branches to other families and reports that family by a branch still preliminary (or a preliminary branch
    comes to outscore the confirmed ones); the family is reported confirmed all the same."""
    sc = sweep_scene(scene)
    scans = list(generate(sc, seed=seed).scans())[:n_scans]
    tracker = tracker_for(request, "mht", None, sc.sensors, lifecycle=lifecycle)
    report, by_preliminary = tracker._report, []

    def spy(scan, time, leaves, shown, chosen):  # which families a preliminary branch stood for
        out = report(scan, time, leaves, shown, chosen)
        if leaves is not None:
            branch = dict(zip(leaves.tracks.track_id[chosen].tolist(), leaves.tracks.status[chosen].tolist()))
            by_preliminary.extend(i for i, s in zip(out.track_id.tolist(), out.status.tolist())
                                  if s == TrackStatus.CONFIRMED and branch.get(i) == TrackStatus.PRELIMINARY)
        return out

    tracker._report = spy
    outs = outputs(tracker, scans)
    assert not broken(outs), broken(outs)
    assert by_preliminary  # the case came up, and the family was reported (confirmed), not left out


@pytest.mark.parametrize("rule", ["mn", "score"])
@pytest.mark.parametrize("max_hypotheses", [1, 5, 20])
def test_mht_reports_a_family_cut_by_the_hypothesis_cap_once(rule, max_hypotheses, request):
    """A family whose chosen leaf the ``max_hypotheses`` cap prunes is reported once, as deleted (if it was
    reported before), not also as live; the cap counts the families it ends."""
    ds = generate(PRESETS["S2"], seed=1)
    tracker = tracker_for(request, "mht", rule, ds.scenario.sensors, max_hypotheses=max_hypotheses)
    outs = outputs(tracker, list(ds.scans())[:12])
    assert not broken(outs), broken(outs)
    assert tracker.deletions["capped"] > 0
    ended = np.concatenate([o.track_id[o.status == TrackStatus.DELETED] for o in outs])
    assert ended.size > 0


@pytest.mark.parametrize("name, rule", OWN_CASES, ids=OWN_IDS)
def test_dense_clutter_keeps_the_status_invariants(name, rule, request):
    """Every tracker but the peers (minutes in such clutter) on 15 scans of S6 at 1,000 clutter points a scan,
    with a loose false-confirmation probability (1e-3) where the rule has one."""
    sc = sweep_scene("S6-c1000")
    scans = list(generate(sc, seed=3).scans())[:15]
    extra = {} if rule is None else {"lifecycle": {"false_confirmation": 1e-3}}
    outs = outputs(tracker_for(request, name, rule, sc.sensors, **extra), scans)
    assert not broken(outs), broken(outs)


@pytest.mark.slow
@pytest.mark.parametrize("name, rule", CONTACT_CASES, ids=[f"{n}-{r}" for n, r in CONTACT_CASES])
@pytest.mark.parametrize("preset", ["S1", "S2", "S3", "S4", "S5", "S6"])
def test_dense_clutter_sweep_keeps_the_status_invariants(preset, name, rule, request):
    """The contact trackers over the whole of each validation preset at 1,000 clutter points a scan, with the
    rule's own settings and with a loose false-confirmation probability."""
    sc = sweep_scene(f"{preset}-c1000")
    ds = generate(sc, seed=1)
    for loose in ({}, {"false_confirmation": 1e-3}):
        lifecycle = {"confirmation": rule, **loose}
        outs = outputs(tracker_for(request, name, None, sc.sensors, lifecycle=lifecycle), ds.scans())
        assert not broken(outs), (loose, broken(outs))
