"""Generated scenes with a sensor of asynchronous reports: each report at its own time inside its window."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from nnda.data.dataset import check_dataset, read_dataset, write_dataset
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.trajectory import evaluate
from nnda.study.track import run_tracker

WINDOW = 10.0  # s


def _ais(reports: bool = True, **change) -> Sensor:
    """A position sensor with 10 s windows (or sweeps), 10 m noise, covering the whole scene, 2 clutter a window."""
    return Sensor(name="ais", kind="position", scan_period_s=WINDOW, reports=reports, sigma_position_m=10.0,
                  min_range_m=0.0, max_range_m=100_000.0, clutter=Clutter(count=2)).model_copy(update=change)


def _ships(late_start_s: float = 0.0) -> list[Target]:
    """Four ships at 5-8 m/s, two of them turning; the last starts ``late_start_s`` into the scene."""
    return [
        Target(name="a", x_m=-3000, y_m=2000, heading_deg=90, speed_m_s=8,
               segments=[Segment(duration_s=300), Segment(duration_s=300, turn_rate_deg_s=0.3)]),
        Target(name="b", x_m=2000, y_m=-4000, heading_deg=0, speed_m_s=6, segments=[Segment(duration_s=600)]),
        Target(name="c", x_m=-1000, y_m=-2000, heading_deg=45, speed_m_s=5,
               segments=[Segment(duration_s=200, turn_rate_deg_s=-0.5), Segment(duration_s=400)]),
        Target(name="d", x_m=4000, y_m=3000, heading_deg=225, speed_m_s=7, start_time_s=late_start_s,
               segments=[Segment(duration_s=600 - late_start_s)]),
    ]


def _scene(sensors: tuple[Sensor, ...], late_start_s: float = 0.0, noise: str = "jitter") -> Scenario:
    return Scenario(name="ships", duration_s=600.0, targets=_ships(late_start_s), sensors=sensors,
                    process_noise=ProcessNoise(model=noise, sigma_accel=0.05))


def test_report_times_lie_in_their_windows_in_order_and_spread_over_them():
    ds = generate(_scene((_ais(),), late_start_s=123.4), seed=3)
    check_dataset(ds, "detections", "truth")
    d = ds.detections
    end = ds.scan_time[d.scan - 1]
    assert np.all((d.time > end - WINDOW) & (d.time <= end))
    assert np.all(np.diff(d.time) > 0)  # one sensor, windows in turn: every row after the one before
    for rows in (d.target_id >= 0, d.is_clutter):  # targets' and clutter's times both uniform in the window
        lag = (end - d.time)[rows] / WINDOW
        assert np.mean(lag == 0) < 0.01 and 0.4 < lag.mean() < 0.6 and lag.min() < 0.05 and lag.max() > 0.95
    assert d.time[d.target_id == 3].min() > 123.4  # a ship reports only once it exists
    scans = list(ds.scans())
    assert all(np.array_equal(s.times, d.time[d.scan == s.index]) for s in scans)
    assert ds.truth.time.tolist() == ds.scan_time[ds.truth.scan - 1].tolist()  # truth at the windows' ends


def test_a_report_measures_its_ship_where_it_was_at_the_report_time():
    ds = generate(_scene((_ais(sigma_position_m=1.0),), noise="none"), seed=5)
    d = ds.detections
    for tid, target in enumerate(ds.scenario.targets):
        rows = d.target_id == tid
        there = evaluate(target, d.time[rows] - target.start_time_s)
        miss = np.hypot(d.x[rows] - there.x, d.y[rows] - there.y)
        assert miss.max() < 6.0  # m: six sigma of 1 m noise per axis; at the window's end it would be tens of m


def test_reports_keep_the_draws_a_sweeping_sensor_makes():
    """A report sensor draws the truth's process noise, the detections and the clutter count as the same sensor
    sweeping would, and a sweep sensor beside it draws exactly what it drew."""
    radar = Sensor(name="radar", scan_period_s=20.0, min_range_m=0.0, max_range_m=100_000.0, pd=0.8)  # on window ends
    sweep = generate(_scene((radar, _ais(reports=False, pd=0.7))), seed=9)
    report = generate(_scene((radar, _ais(pd=0.7))), seed=9)
    # a window comes before a sweep at its end's instant, so the scans are numbered apart: rows by (time, sensor)
    truth = [ds.truth for ds in (sweep, report)]
    rows = [np.lexsort((t.target_id, ds.scan_sensor[t.scan - 1], t.time)) for t, ds in zip(truth, (sweep, report))]
    for name in ("x", "y", "detected"):
        np.testing.assert_array_equal(getattr(truth[1], name)[rows[1]], getattr(truth[0], name)[rows[0]])
    by_radar = sweep.detections.sensor == 0, report.detections.sensor == 0
    for name in ("time", "range", "azimuth", "target_id"):
        a, b = (getattr(ds.detections, name)[rows] for ds, rows in zip((sweep, report), by_radar))
        np.testing.assert_array_equal(b, a)
    counts = [np.bincount(ds.detections.scan[ds.detections.is_clutter], minlength=ds.n_scans + 1)[1:][
        np.lexsort((ds.scan_sensor, ds.scan_time))] for ds in (sweep, report)]
    np.testing.assert_array_equal(counts[1], counts[0])
    assert not np.array_equal(report.detections.time, sweep.detections.time)


def test_reports_are_reproducible_and_round_trip_through_a_dataset_directory(tmp_path):
    a = generate(_scene((_ais(),)), seed=4, run=2)
    b = read_dataset(write_dataset(a, tmp_path / "ais"))
    assert b.scenario == a.scenario and b.scenario.sensors[0].reports
    c = generate(_scene((_ais(),)), seed=4, run=2)
    for name in ("scan", "time", "x", "y", "target_id"):
        np.testing.assert_array_equal(getattr(b.detections, name), getattr(a.detections, name))
        np.testing.assert_array_equal(getattr(c.detections, name), getattr(a.detections, name))
    assert not np.array_equal(generate(_scene((_ais(),)), seed=4, run=3).detections.time[:20], a.detections.time[:20])


LIFE = {"v_min": 0.0, "v_max": 20.0, "confirmation": "mn", "m": 3, "n": 5}
SHIPS = {"cv_sigma_q": 0.05, "ct_sigma_q": 0.05, "noise": "continuous"}


def _gospa(reports: bool, runs: range) -> tuple[float, float]:
    """gnn's GOSPA (m, cut-off 1000 m) on the four ships: mean over scans and runs, and over scans 11.. (after
    every track is confirmed)."""
    whole, settled = [], []
    for run in runs:
        scores = run_tracker(generate(_scene((_ais(reports),)), seed=0, run=run), "gnn",
                             {"lifecycle": LIFE, "motion": SHIPS}).scores
        whole.append(scores.values["gospa"])
        settled.append(scores.series["gospa"][10:].mean())
    return float(np.mean(whole)), float(np.mean(settled))


def test_gnn_tracks_generated_reports_about_as_well_as_sweeps():
    """Runs 0-1 here: gnn's mean GOSPA 118.9 m on reports, 120.3 m on sweeps; 26.2 and 21.5 m after scan 10.
    Over runs 0-19: 119.6 and 113.9 m (initiation dominates: 4 windows without confirmed tracks cost 1414 m
    each), 25.8 and 20.3 m after scan 10 (a report is up to a window older than the estimate at the window's
    end)."""
    report, sweep = _gospa(True, range(2)), _gospa(False, range(2))
    assert report[0] < 1.1 * sweep[0]
    assert report[1] < 35.0 and sweep[1] < 30.0


def test_the_ais_harbour_preset_is_a_report_stream_gnn_tracks_ship_by_ship():
    ds = generate(PRESETS["ais-harbour"])
    check_dataset(ds, "detections", "truth")
    d = ds.detections
    assert ds.scenario.sensors[0].reports and np.mean(d.time == ds.scan_time[d.scan - 1]) < 0.01
    run = run_tracker(ds, "gnn", {"lifecycle": LIFE, "motion": SHIPS})
    assert run.outputs[-1].confirmed.sum() == 10
    assert run.scores.values["false_tracks"] == 0 and run.scores.values["track_breaks"] == 0
    assert run.scores.values["position_rmse_m"] < 15.0  # m: 11.3 measured at the preset's seed


def test_no_other_scan_may_fall_inside_a_report_window():
    """A tracker takes a window of reports whole, so a sweep inside one (a 2 s radar beside 10 s windows) would
    put the window's earlier reports behind it: the scenario refuses it, naming both sensors and the fix; scans
    on the windows' ends (the radar every 10 or 20 s, or 2 s windows beside the 2 s radar) are accepted."""
    scene = PRESETS["ais-harbour"]
    ais = scene.sensors[0].model_dump()
    radar = Sensor(name="radar", kind="position", scan_period_s=2.0, sigma_position_m=20.0).model_dump()
    data = scene.model_dump()
    with pytest.raises(ValidationError, match=r"sensor 1 \('radar'\) has a sweep at t = 2 s, inside the window "
                                              r"\(0, 10\] s of report sensor 0 \('ais'\).*scan_period_s = 2"):
        Scenario.model_validate({**data, "sensors": [ais, radar]})
    offset = {**radar, "scan_period_s": 10.0, "scan_offset_s": 5.0}
    with pytest.raises(ValidationError, match=r"at t = 5 s, inside the window \(0, 10\]"):
        Scenario.model_validate({**data, "sensors": [ais, offset]})
    other = {**ais, "name": "adsb", "scan_period_s": 4.0}  # another report sensor: its windows end inside too
    with pytest.raises(ValidationError, match=r"sensor 1 \('adsb'\) has a window ending at t = 4 s"):
        Scenario.model_validate({**data, "sensors": [ais, other]})
    for sensors in ([ais, {**radar, "scan_period_s": 10.0}], [ais, {**radar, "scan_period_s": 20.0}],
                    [{**ais, "scan_period_s": 2.0}, radar]):
        Scenario.model_validate({**data, "sensors": sensors})
