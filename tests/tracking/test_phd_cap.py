"""The PHD trackers' mixture cap (J_max): what it drops is counted and warned of once a run, and by default it
grows with the expected target count, so a scene of many targets keeps them all."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import BoundWarning
from nnda.tracking.phd import tracker as phd_tracker
from nnda.tracking.phd.config import SINGLE_SCAN_EXTRACTION
from nnda.tracking.registry import make_tracker


def many_targets(n: int, scans: int = 8) -> Scenario:
    """``n`` straight targets spread over a 100 km radar's ring, P_D 0.9, 20 clutter points a scan."""
    rng = np.random.default_rng(0)
    r, az = np.sqrt(rng.uniform(20e3**2, 90e3**2, n)), rng.uniform(0.0, 2 * np.pi, n)
    targets = [Target(name=f"t{i}", x_m=float(r[i] * np.sin(az[i])), y_m=float(r[i] * np.cos(az[i])),
                      heading_deg=float(rng.uniform(0, 360)), speed_m_s=200.0,
                      segments=[Segment(duration_s=2.0 * scans)]) for i in range(n)]
    sensor = Sensor(max_range_m=100e3, pd=0.9, clutter=Clutter(law="annulus", count=20))
    return Scenario(name="many", duration_s=2.0 * scans, targets=targets, sensors=(sensor,))


@pytest.mark.parametrize("name", ["ekphd", "cphd"])
def test_what_the_cap_drops_is_counted_and_warned_of_once_a_run(name, monkeypatch):
    """A J_max of 3 on S1 (four targets in its first 20 s, 100 clutter points a scan): every scan's merged mixture
    beyond it is counted, with its weight; one BoundWarning a run, once a scan drops a target's worth of weight,
    naming the tracker and the config field."""
    merged = []
    merge = phd_tracker.merge

    def spy(*args, **kwargs):
        out = merge(*args, **kwargs)
        merged.append((len(out), np.sort(out.weights)[::-1]))
        return out

    monkeypatch.setattr(phd_tracker, "merge", spy)
    ds = generate(PRESETS["S1"].model_copy(update={"duration_s": 20.0}), 0)
    tracker = make_tracker(name, ds.scenario.sensor, {"max_components": 3, "components_per_contact": 0,
                                                      "components_per_target": None})
    for run in range(2):
        merged.clear()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for scan in ds.scans():
                tracker.step(scan)
                assert len(tracker.mixture) <= 3
        bound = [str(w.message) for w in caught if issubclass(w.category, BoundWarning)]
        assert len(bound) == 1, bound
        assert bound[0].startswith(f"{name}, t = ") and "config field max_components = 3" in bound[0]
        assert tracker.n_capped_components == sum(max(n - 3, 0) for n, _ in merged) > 0
        assert tracker.capped_weight == pytest.approx(sum(w[3:].sum() for _, w in merged), rel=1e-9)
        tracker.reset()  # a new run: counted from zero and warned of again
        assert tracker.n_capped_components == 0 and tracker.capped_weight == 0.0


def test_a_cap_that_does_not_bind_says_nothing():
    ds = generate(PRESETS["S1"].model_copy(update={"duration_s": 20.0}), 0)
    tracker = make_tracker("ekphd", ds.scenario.sensor, {"max_components": 10_000})
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundWarning)
        for scan in ds.scans():
            tracker.step(scan)
    assert tracker.n_capped_components == 0 and tracker.capped_weight == 0.0


def test_the_cap_grows_with_the_expected_target_count():
    """150 targets against the radar preset's J_max of 100 with the radar thesis's pinned settings (no growth
    with the contacts): the cap alone would keep the components of at most ~100 of them, and report fewer;
    grown to 2 x the expected target count (the preset's components_per_target) it follows most (133 after 8 scans)."""
    ds = generate(many_targets(150), 0)
    reported = {}
    for per_target in (None, 2.0):
        tracker = make_tracker("ekphd", ds.scenario.sensor, {**SINGLE_SCAN_EXTRACTION,
                                                             "components_per_target": per_target})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BoundWarning)
            for scan in ds.scans():
                out = tracker.step(scan)
                mass = tracker.cardinality.mean
                assert len(tracker.mixture) <= max(100, int(np.ceil((per_target or 0) * mass)))
        reported[per_target] = len(out)
    assert reported[None] <= 100 and reported[2.0] >= 120, reported
    assert make_tracker("ekphd", Sensor()).config.components_per_target == 2.0  # the radar preset's default


def test_the_growth_changes_nothing_at_a_few_targets():
    """S3 (eight targets, 100 clutter points a scan) with the pinned settings: the same tracks with the growth
    as without it (2 x a handful of targets is far below J_max)."""
    ds = generate(PRESETS["S3"].model_copy(update={"duration_s": 60.0}), 1)
    outputs = {}
    for per_target in (None, 2.0):
        tracker = make_tracker("cphd", ds.scenario.sensor, {**SINGLE_SCAN_EXTRACTION,
                                                            "components_per_target": per_target})
        outputs[per_target] = [tracker.step(scan) for scan in ds.scans()]
    for a, b in zip(outputs[None], outputs[2.0], strict=True):
        np.testing.assert_array_equal(a.track_id, b.track_id)
        np.testing.assert_array_equal(a.state, b.state)
