"""Stone Soup peers on several sensors: the `two-radars` preset, and sensors of position fixes."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.data.sensor import cart_to_polar_at, in_coverage, wrap_angle
from nnda.study.metrics import run_metrics
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import PEERS, make_tracker

pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")

from stonesoup.types.state import State  # noqa: E402
from stonesoup.types.update import Update  # noqa: E402

from nnda.peers.adapter import measurement_model, to_detections, to_seconds  # noqa: E402

TWO = PRESETS["two-radars"]


def _quiet(scene: Scenario, duration_s: float, clutter: int = 5) -> Scenario:
    """``scene`` over ``duration_s`` with ``clutter`` contacts a scan per sensor (the peers are slow in clutter)."""
    sensors = tuple(s.model_copy(update={"clutter": Clutter(count=clutter)}) for s in scene.sensors)
    return scene.model_copy(update={"sensors": sensors, "duration_s": duration_s})


def _outputs(name: str, scene: Scenario, seed: int):
    ds = generate(scene, seed)
    tracker = make_tracker(name, ds.scenario.sensors)
    return ds, tracker, [tracker.step(scan) for scan in ds.scans()]


def _miss_m(outs, truth, scans: np.ndarray) -> np.ndarray:
    """Per truth row of ``scans`` (scan indices): the distance (m) to the nearest confirmed track, inf if none."""
    rows = np.flatnonzero(np.isin(truth.scan, scans))
    out = np.full(len(rows), np.inf)
    for i, r in enumerate(rows):
        o = outs[truth.scan[r] - 1]
        xy = o.state[o.status == TrackStatus.CONFIRMED][:, [0, 2]]
        if len(xy):
            out[i] = np.hypot(xy[:, 0] - truth.x[r], xy[:, 1] - truth.y[r]).min()
    return out


@pytest.mark.parametrize("name", sorted(PEERS))
def test_two_radars_every_target_both_see_is_tracked(name):
    """Each peer confirms a track on every target both radars see and keeps it within 300 m of the truth over
    the second half of the run (the GM-PHD's weight falls below extraction at a scan that misses the target,
    as our ekphd's does on this run: there only)."""
    scene = _quiet(TWO, 40.0)
    ds, _, outs = _outputs(name, scene, seed=1)
    t = ds.truth
    both = in_coverage(scene.sensors[0], t.x, t.y) & in_coverage(scene.sensors[1], t.x, t.y)
    late = np.isin(t.scan, np.arange(ds.n_scans // 2, ds.n_scans + 1))
    assert np.unique(t.target_id[both & late]).size >= 3  # the scene tests something
    near = _miss_m(outs, t, np.unique(t.scan[late]))[both[late]] < 300.0
    excused = ~t.detected[late][both[late]] if name == "stonesoup-gmphd" else np.zeros(near.size, bool)
    assert (near | excused).all() and near.mean() > 0.85, near.mean()
    m = run_metrics(ds, outs, ownership="position" if name == "stonesoup-gmphd" else "auto")
    assert m.lost_targets == 0 and m.false_tracks <= (1 if name == "stonesoup-gmphd" else 0)


@pytest.mark.parametrize("name", sorted(PEERS))
def test_a_track_outside_the_sweeping_radars_sector_takes_no_miss(name):
    """A target only the west radar sees, missed by it twice in a row: the east radar's sweeps count no miss
    against its track (Stone Soup's deleter counting every scan would drop it at the second miss; a GM-PHD
    giving it the east radar's P_D would thin it below extraction at every east sweep; the GM-PHD's weight
    is below extraction from the first miss until the second west sweep after the last, scans 30-35)."""
    west_only = Target(name="west-only", x_m=18_000.0, y_m=2_000.0, heading_deg=0.0, speed_m_s=100.0,
                       segments=[Segment(duration_s=50.0)], missed_scans=[30, 32])  # two west sweeps
    sensors = tuple(s.model_copy(update={"pd": 1.0, "clutter": Clutter(law="none")}) for s in TWO.sensors)
    scene = TWO.model_copy(update={"duration_s": 50.0, "targets": [west_only], "sensors": sensors})
    ds, _, outs = _outputs(name, scene, seed=3)
    t = ds.truth
    assert in_coverage(sensors[0], t.x, t.y).all() and not in_coverage(sensors[1], t.x, t.y).any()
    assert (ds.scan_sensor[[29, 31]] == 0).all() and not t.detected[np.isin(t.scan, [30, 32])].any()
    scans = np.arange(16, ds.n_scans + 1)
    if name == "stonesoup-gmphd":
        scans = scans[(scans < 30) | (scans > 35)]
    assert (_miss_m(outs, t, scans) < 300.0).all()


@pytest.mark.parametrize("name", sorted(PEERS))
def test_position_fixes_alone_and_with_a_radar(name, three_targets):
    """A sensor of position fixes, alone and sweeping between a radar's scans, tracks every target."""
    fixes = Sensor(name="fixes", kind="position", sigma_position_m=40.0, scan_offset_s=1.0,
                   clutter=Clutter(law="none"))
    radar = Sensor(name="radar", clutter=Clutter(law="none"))
    for sensors in [(fixes,), (radar, fixes)]:
        scene = three_targets.model_copy(update={"sensors": sensors})
        ds, _, outs = _outputs(name, scene, seed=1)
        miss = _miss_m(outs, ds.truth, np.arange(ds.n_scans // 2, ds.n_scans + 1))
        assert (miss < 150.0).all(), (len(sensors), np.sort(miss)[-5:])


def test_each_detection_carries_its_sensors_model():
    """The east radar's detections update the tracks with the east radar's model (offset 10 km east), the west
    radar's with the west's: without the offset the same contact would lie 10 to 20 km away."""
    ds, tracker, _ = _outputs("stonesoup-gnn", _quiet(TWO, 30.0), seed=1)
    west, east = tracker.models
    np.testing.assert_array_equal(np.ravel(west.translation_offset), [0.0, -10_000.0])  # (y, x) of the radar
    np.testing.assert_array_equal(np.ravel(east.translation_offset), [0.0, 10_000.0])
    by_sensor = np.zeros(2, int)
    for track in tracker.tracker.tracks:
        for state in track:
            if isinstance(state, Update) and state.hypothesis:
                sensor = int(ds.scan_sensor[round(to_seconds(state.timestamp)) - 1])
                assert state.hypothesis.measurement.measurement_model is tracker.models[sensor]
                by_sensor[sensor] += 1
    assert (by_sensor > 10).all(), by_sensor


def test_the_models_of_a_radar_away_from_the_origin_and_of_position_fixes():
    """Stone Soup's bearing from a radar at (x_s, y_s) is our azimuth from it (the offset in the mapping's
    order, y then x); a position sensor's model reads (x, y) with sigma_position_m^2 I."""
    radar = Sensor(x_m=-7_000.0, y_m=4_000.0, sigma_range_m=25.0, sigma_azimuth_mrad=2.0)
    fixes = Sensor(kind="position", sigma_position_m=40.0)
    polar, position = measurement_model(radar), measurement_model(fixes)
    rng = np.random.default_rng(0)
    for x, y in rng.uniform(-30_000, 30_000, (20, 2)):
        state = State([[x], [10.0], [y], [-5.0]])
        az, r = (float(v) for v in polar.function(state).ravel())
        r0, az0 = cart_to_polar_at(radar.position, x, y)
        assert abs(r - r0) < 1e-6 and abs(wrap_angle(az - az0)) < 1e-12
        np.testing.assert_array_equal(np.ravel(position.function(state)), [x, y])
    np.testing.assert_array_equal(position.covar(), 1_600.0 * np.eye(2))
    dets = to_detections(Scan(3, 6.0, np.array([[-100.0, 250.0], [7.0, -8.0]]), sensor=1), position)
    assert sorted((d.metadata["row"], *np.ravel(d.state_vector)) for d in dets) == [(0, -100.0, 250.0), (1, 7.0, -8.0)]
