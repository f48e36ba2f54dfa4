"""Trackers on several sensors: two radars' scans refine the same tracks (the `two-radars` preset)."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Scenario, Segment, Sensor, Target
from nnda.data.sensor import in_coverage
from nnda.errors import ConfigError, TrackingError
from nnda.study.metrics import run_metrics
from nnda.tracking.registry import make_tracker

TWO = PRESETS["two-radars"]


def _alone(sensor: int) -> Scenario:
    """The same scene seen by one of its radars (the west one alone draws exactly its contacts of the pair)."""
    return TWO.model_copy(update={"sensors": (TWO.sensors[sensor],)})


def _gospa(name: str, scenario: Scenario, seed: int, config: dict | None = None) -> float:
    ds = generate(scenario, seed)
    tracker = make_tracker(name, ds.scenario.sensors, config)
    return float(np.mean(run_metrics(ds, [tracker.step(scan) for scan in ds.scans()]).gospa))  # per-scan mean, m


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_two_radars_track_better_than_either_alone(name):
    """Each radar sees each target only part of the time; both together follow every target longer."""
    both = _gospa(name, TWO, seed=3)
    west, east = _gospa(name, _alone(0), seed=3), _gospa(name, _alone(1), seed=3)
    assert both < 0.85 * min(west, east), (both, west, east)


def test_a_track_outside_the_sweeping_radars_sector_takes_no_miss():
    """A target seen only by the west radar keeps its track through the east radar's sweeps."""
    west_only = Target(name="west-only", x_m=18_000.0, y_m=2_000.0, heading_deg=0.0, speed_m_s=100.0,
                       segments=[Segment(duration_s=70.0)])  # inside the west sector, east of the east one
    sc = TWO.model_copy(update={"duration_s": 70.0, "targets": [west_only]})
    ds = generate(sc, 3)
    truth = ds.truth
    assert in_coverage(sc.sensors[0], truth.x, truth.y).all() and not in_coverage(sc.sensors[1], truth.x, truth.y).any()
    for name in ("gnn", "mht"):
        tracker = make_tracker(name, ds.scenario.sensors)
        m = run_metrics(ds, [tracker.step(scan) for scan in ds.scans()])
        assert m.track_breaks == 0 and m.lost_targets == 0 and m.confirmed_tracks - m.false_tracks == 1, name


@pytest.mark.parametrize("name", ["gnn", "mht", "jpda"])
def test_each_radars_contacts_update_the_tracks(name):
    ds = generate(TWO, seed=3)
    tracker = make_tracker(name, ds.scenario.sensors)
    outs = [tracker.step(scan) for scan in ds.scans()]
    m = run_metrics(ds, outs)
    assert m.lost_targets == 0 and m.false_tracks <= 1
    used_by = np.zeros(2, int)  # contacts used by confirmed tracks, per radar
    for o, sensor in zip(outs, ds.scan_sensor):
        used_by[sensor] += int(((o.status == 2) & (o.contact >= 0)).sum())
    assert (used_by > 0.3 * used_by.sum()).all(), used_by


def test_a_scan_from_an_unknown_sensor_is_refused():
    tracker = make_tracker("gnn", TWO.sensors)
    tracker.step(Scan(1, 1.0, np.empty((0, 2)), sensor=1))
    with pytest.raises(TrackingError, match=r"scan 2 comes from sensor 2, but this tracker was built for 2 sensor"):
        tracker.step(Scan(2, 2.0, np.array([[10_000.0, 0.5]]), sensor=2))


def test_position_sensor_contacts_are_not_ranges():
    sensor = Sensor(kind="position", sigma_position_m=5.0, name="fixes")
    tracker = make_tracker("gnn", sensor)
    tracker.step(Scan(1, 2.0, np.array([[-100.0, 50.0]])))  # a negative x is a position, not a bad range
    with pytest.raises(TrackingError, match=r"contact 0 is invalid \[nan, 1.0\] \(non-finite\)"):
        tracker.step(Scan(2, 4.0, np.array([[np.nan, 1.0]])))


@pytest.mark.parametrize("name", ["ekphd", "cphd"])
def test_a_phd_component_outside_the_sweeping_radars_sector_is_not_thinned(name):
    """The west-only target stays reported through the east radar's sweeps: that radar's p_D is 0 where it
    cannot see (with its p_D everywhere, every east sweep would cut the weight to 1 - p_D, below extraction)."""
    west_only = Target(name="west-only", x_m=18_000.0, y_m=2_000.0, heading_deg=0.0, speed_m_s=100.0,
                       segments=[Segment(duration_s=70.0)])
    sc = TWO.model_copy(update={"duration_s": 70.0, "targets": [west_only]})
    ds = generate(sc, 3)
    tracker = make_tracker(name, ds.scenario.sensors, {"sensor_pd": [0.9, 0.85], "extraction_scans": 1})
    outs = [tracker.step(scan) for scan in ds.scans()]
    t = ds.truth
    near = [bool(len(o.state)) and np.hypot(o.state[:, 0] - x, o.state[:, 2] - y).min() < 300.0
            for o, x, y in zip(outs, t.x, t.y)]
    east = ds.scan_sensor[4:] == 1
    assert np.mean(np.asarray(near[4:])[east]) >= 0.9 and np.mean(near[4:]) >= 0.85


def test_two_radars_help_a_phd_tracker():
    """Over three runs the EK-PHD on both radars (each with its own p_D) beats it on either radar alone."""
    def mean_gospa(sensors: tuple[int, ...], pd: list[float]) -> float:
        sc = TWO.model_copy(update={"sensors": tuple(TWO.sensors[s] for s in sensors)})
        return float(np.mean([_gospa("ekphd", sc, seed, {"sensor_pd": pd}) for seed in (3, 4, 5)]))

    both, west, east = mean_gospa((0, 1), [0.9, 0.85]), mean_gospa((0,), [0.9]), mean_gospa((1,), [0.85])
    assert both < 0.95 * min(west, east), (both, west, east)


def test_phd_trackers_take_each_radars_detection_probability():
    tracker = make_tracker("cphd", TWO.sensors, {"sensor_pd": [0.9, 0.6]})
    assert [v.pd for v in tracker.views] == [0.9, 0.6]
    with pytest.raises(ConfigError, match=r"sensor_pd gives 1 detection probabilities for 2 sensor\(s\) \(west, "
                                            r"east\)"):
        make_tracker("ekphd", TWO.sensors, {"sensor_pd": [0.9]})
    with pytest.raises(ConfigError, match="sensor_pd"):
        make_tracker("ekphd", TWO.sensors, {"sensor_pd": [0.9, 1.5]})


@pytest.mark.parametrize("name", ["gmphd", "cphd"])
def test_one_sensors_own_detection_probability_is_its_pd(name):
    """``sensor_pd`` of the one sensor runs exactly as ``pd`` (the single-sensor path is unchanged)."""
    ds = generate(_alone(0), seed=4)
    runs = [[make_tracker(name, ds.scenario.sensors, cfg).step(scan) for scan in ds.scans()]
            for cfg in ({"pd": 0.8}, {"pd": 0.5, "sensor_pd": [0.8]})]
    assert all(np.array_equal(a.state, b.state) for a, b in zip(*runs))


def _simultaneous(offset_s: float) -> Scenario:
    """The two-radar scene with the second radar sweeping ``offset_s`` after the first (0: at the same instants)."""
    return TWO.model_copy(update={"sensors": (TWO.sensors[0], TWO.sensors[1].model_copy(
        update={"scan_offset_s": offset_s}))})


@pytest.mark.parametrize("name", ["gnn", "jpda", "mht", "gmphd", "fusion-aa"])
def test_two_sensors_sweeping_at_one_instant_are_tracked(name):
    """Two radars whose sweeps fall at the same times: each scan at a time equal to the previous one's comes from
    the other sensor, and the tracker takes it (no prediction over 0 s); the tracking is as good as with the
    sweeps apart."""
    together = generate(_simultaneous(0.0), 3)
    assert (np.diff(together.scan_time) == 0).any()
    at_once = _gospa(name, _simultaneous(0.0), seed=3)
    apart = _gospa(name, _simultaneous(TWO.sensors[0].scan_period_s / 2), seed=3)
    assert at_once < 1.25 * apart, (at_once, apart)


@pytest.mark.parametrize("name", ["gnn", "gmphd", "fusion-aa"])
def test_one_sensor_twice_at_one_instant_is_refused(name):
    tracker = make_tracker(name, TWO.sensors)
    tracker.step(Scan(1, 2.0, np.empty((0, 2)), 0))
    tracker.step(Scan(2, 2.0, np.empty((0, 2)), 1))  # the other sensor at the same instant: taken
    with pytest.raises(TrackingError, match=r"does not come after the previous scan \(t = 2.0 s, sensor 1\)"):
        tracker.step(Scan(3, 2.0, np.empty((0, 2)), 1))
    with pytest.raises(TrackingError, match="does not come after"):
        tracker.step(Scan(3, 1.0, np.empty((0, 2)), 0))
