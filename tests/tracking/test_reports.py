"""Asynchronous reports: the contact trackers take a window of reports, each at its own time."""

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, TrackingError
from nnda.tracking.output import NO_CONTACT
from nnda.tracking.registry import make_tracker
from nnda.tracking.reports import time_groups

WINDOW = 10.0
REPORTER = Sensor(name="ais", kind="position", reports=True, scan_period_s=WINDOW, sigma_position_m=10.0,
                  min_range_m=0.0, max_range_m=100_000.0)
LIFE = {"v_min": 0.0, "v_max": 20.0, "confirmation": "mn", "m": 3, "n": 5}
SHIPS = {"cv_sigma_q": 0.05, "ct_sigma_q": 0.05, "noise": "continuous"}  # ships, in continuous time


def stream(n_targets: int, duration: float, seed: int, stop: dict[int, float] | None = None):
    """Reports of ``n_targets`` ships moving straight at up to 8 m/s, each reporting every 3-12 s with 20 %
    jitter, 10 m noise: times (R,), positions (R, 2), target index (R,), start (n, 2) m and velocity (n, 2)."""
    rng = np.random.default_rng(seed)
    p0 = rng.uniform(-20_000, 20_000, (n_targets, 2))
    v = rng.uniform(-8, 8, (n_targets, 2))
    times, who = [], []
    for i in range(n_targets):
        every, end = rng.uniform(3, 12), (stop or {}).get(i, duration)
        t = rng.uniform(0.01, every)
        while t < end:
            times.append(t)
            who.append(i)
            t += every * rng.uniform(0.8, 1.2)
    order = np.argsort(times, kind="stable")
    t, who = np.asarray(times)[order], np.asarray(who)[order]
    return t, p0[who] + v[who] * t[:, None] + rng.normal(0, 10, (t.size, 2)), who, p0, v


def windows(t: np.ndarray, z: np.ndarray, duration: float):
    """The report windows (s - W, s] of the stream as scans k = 1.. (each with its reports' own times)."""
    k = np.ceil(t / WINDOW).astype(int)
    for s in range(1, int(np.ceil(duration / WINDOW)) + 1):
        rows = k == s
        yield Scan(s, s * WINDOW, z[rows], 0, t[rows])


def run(name: str, t, z, duration: float, **life):
    tracker = make_tracker(name, [REPORTER], {"lifecycle": LIFE | life, "motion": SHIPS})
    return tracker, [tracker.step(scan) for scan in windows(t, z, duration)]


@pytest.mark.parametrize("name", ["gnn", "jpda", "mht"])
def test_each_ship_gets_one_track_and_no_misses_are_counted(name):
    t, z, _, p0, v = stream(6, 400.0, seed=3)
    tracker, outs = run(name, t, z, 400.0)
    last = outs[-1]
    assert last.confirmed.sum() == 6
    assert np.unique(np.concatenate([o.track_id[o.confirmed] for o in outs])).size == 6
    assert sum(tracker.deletions.values()) == 0
    truth = p0 + v * last.time
    err = np.hypot(*(last.state[last.confirmed][:, [0, 2]][:, None] - truth[None]).transpose(2, 0, 1)).min(axis=1)
    assert err.max() < 60.0  # m: each track on its ship at the window's end (10 m reports, one every <= 14 s)


def test_one_target_equals_its_imm_run_report_by_report():
    """The track of one target is the IMM's two-point start and update at each report's own time, predicted
    to the window's end (1e-9 relative)."""
    t, z, *_ = stream(1, 200.0, seed=5)
    tracker, outs = run("gnn", t, z, 200.0)
    imm = tracker.filter
    state = imm.start(z[:1], z[1:2], *(np.broadcast_to(imm.measurement.R, (1, 2, 2)),), t[1] - t[0])
    for k in range(2, t.size):
        state = imm.update(imm.predict(state, t[k] - t[k - 1]), z[k:k + 1])
    end = outs[-1]
    x, P = imm.estimate(imm.predict(state, end.time - t[-1]).state)
    np.testing.assert_allclose(end.state, x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(end.covariance, P, rtol=1e-9, atol=1e-9)


def test_a_ship_that_stops_reporting_is_deleted_after_the_gap():
    """M/N: each window's end after ``report_gap_s`` without a report is a miss; the fourth deletes."""
    t, z, who, *_ = stream(3, 600.0, seed=7, stop={0: 200.0})
    tracker, outs = run("gnn", t, z, 600.0, report_gap_s=30.0, max_misses=3)
    last_report = t[who == 0].max()
    alive = {int(i) for o in outs for i in o.track_id[o.confirmed]}
    deleted_at = [o.time for o in outs if (o.status == 3).any()]  # DELETED
    assert len(alive) == 3 and tracker.deletions["misses"] == 1
    assert last_report + 30.0 < deleted_at[0] <= last_report + 30.0 + 5 * WINDOW


def test_a_window_reports_each_track_with_the_row_of_its_last_report():
    t, z, who, *_ = stream(2, 300.0, seed=11)
    _, outs = run("gnn", t, z, 300.0)
    k = np.ceil(t / WINDOW).astype(int)
    last = outs[-1]
    rows = np.flatnonzero(k == k.max())
    took = last.contact[last.contact != NO_CONTACT]
    assert took.size and set(took.tolist()) <= set(range(rows.size))
    for target in np.unique(who[rows]):  # a track's row is its target's last report of the window
        mine = np.flatnonzero(who[rows] == target)
        assert mine.max() in took


def test_reports_at_one_time_stamp_are_taken_together():
    assert time_groups(np.array([1.0, 1.0, 2.0, 3.0, 3.0])).tolist() == [0, 2, 3, 5]
    tracker = make_tracker("gnn", [REPORTER], {"lifecycle": LIFE})
    z = np.array([[0.0, 0.0], [5_000.0, 0.0]])
    for k in range(1, 6):  # two still ships reporting at the same instants
        out = tracker.step(Scan(k, k * WINDOW, z, 0, np.full(2, k * WINDOW - 5.0)))
    assert out.confirmed.sum() == 2


@pytest.mark.parametrize("name", ["gmphd", "nn", "pmbm"])
def test_trackers_without_reports_refuse_them_by_name(name):
    with pytest.raises(ConfigError, match=r"does not take asynchronous reports \(sensor 'ais'.*gnn, jpda, mht"):
        make_tracker(name, [REPORTER])


@pytest.mark.parametrize("times, match", [
    (None, "carries no report times"),
    (np.array([1.0]), r"2 report\(s\) but report times of shape \(1,\)"),
    (np.array([3.0, 2.0]), "non-decreasing"),
    (np.array([1.0, np.nan]), "finite"),
    (np.array([1.0, 11.0]), "at most at its end"),
])
def test_bad_report_times_are_refused_naming_the_scan(times, match):
    tracker = make_tracker("gnn", [REPORTER], {"lifecycle": LIFE})
    with pytest.raises(TrackingError, match=match):
        tracker.step(Scan(1, WINDOW, np.zeros((2, 2)), 0, times))


def test_a_window_before_the_last_is_refused():
    tracker = make_tracker("mht", [REPORTER], {"lifecycle": LIFE})
    tracker.step(Scan(1, WINDOW, np.zeros((1, 2)), 0, np.array([5.0])))
    with pytest.raises(TrackingError, match="does not come after the previous scan"):
        tracker.step(Scan(2, WINDOW, np.zeros((1, 2)), 0, np.array([9.0])))


def test_a_radar_sweeping_at_the_windows_ends_is_fused_with_the_reports():
    """At one time a window of reports comes before the sweeps (its reports lie before), whichever sensor is
    listed first; both sensors update the same tracks."""
    from nnda.data.generator import generate
    from nnda.data.presets import PRESETS

    scene = PRESETS["ais-harbour"]
    ais = scene.sensors[0]
    radar = Sensor(name="radar", kind="position", scan_period_s=ais.scan_period_s, sigma_position_m=20.0,
                   min_range_m=0.0, max_range_m=ais.max_range_m, x_m=ais.x_m, y_m=ais.y_m)
    both = scene.model_copy(update={"sensors": (radar, ais)})
    data = generate(both, 0)
    assert data.scan_sensor[:2].tolist() == [1, 0] and data.scan_time[0] == data.scan_time[1]
    tracker = make_tracker("gnn", both.sensors, {"lifecycle": LIFE})
    outs = [tracker.step(scan) for scan in data.scans()]
    assert outs[-1].confirmed.sum() == len(scene.targets)


def test_reports_in_windows_of_a_faster_radars_period_are_fused_with_its_sweeps():
    """A 2 s radar beside AIS: with the reports grouped into windows of the radar's period (the scenario
    refuses 10 s windows around its sweeps), every report is taken in time order between the sweeps, and the
    two sensors together track every ship with no false track."""
    from nnda.data.generator import generate
    from nnda.data.presets import PRESETS
    from nnda.study.metrics import run_metrics

    scene = PRESETS["ais-harbour"]
    ais = scene.sensors[0].model_copy(update={"scan_period_s": 2.0})
    radar = Sensor(name="radar", kind="position", scan_period_s=2.0, sigma_position_m=30.0, pd=0.9,
                   min_range_m=0.0, max_range_m=ais.max_range_m, x_m=ais.x_m, y_m=ais.y_m)
    both = scene.model_copy(update={"sensors": (ais, radar)})
    data = generate(both, 0)
    tracker = make_tracker("gnn", both.sensors, {"lifecycle": LIFE})
    m = run_metrics(data, [tracker.step(scan) for scan in data.scans()])
    assert m.false_tracks == 0 and m.lost_targets == 0 and m.hit_rate > 97.0
