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


def _gospa(name: str, scenario: Scenario, seed: int) -> float:
    ds = generate(scenario, seed)
    tracker = make_tracker(name, ds.scenario.sensors)
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


def test_single_radar_trackers_refuse_two_radars(model_file):
    with pytest.raises(ConfigError, match="tracker 'nn' works with one polar sensor; this scenario has west"):
        make_tracker("nn", TWO.sensors, {"model": str(model_file)})


def test_position_sensor_contacts_are_not_ranges():
    sensor = Sensor(kind="position", sigma_position_m=5.0, name="fixes")
    tracker = make_tracker("gnn", sensor)
    tracker.step(Scan(1, 2.0, np.array([[-100.0, 50.0]])))  # a negative x is a position, not a bad range
    with pytest.raises(TrackingError, match=r"contact 0 is invalid \[nan, 1.0\] \(non-finite\)"):
        tracker.step(Scan(2, 4.0, np.array([[np.nan, 1.0]])))
