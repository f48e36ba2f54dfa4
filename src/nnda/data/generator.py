"""Scenario generator: noise-free truth + process noise + measurement noise + clutter + gaps.

After the scenario generator of Vargas Avila (2015). The noise-free part
(trajectories sampled at the scan times of every sensor) is computed once
per scenario in a `Plan`; each run then draws its own noise, detections
and clutter, vectorised over all scans and targets of one sensor at a time.

Random streams: run ``i`` of seed ``s`` of scenario ``name`` uses, for its
first sensor, ``SeedSequence(s, spawn_key=(crc32(name), i))`` and, for
sensor ``j >= 1``, ``SeedSequence(s, spawn_key=(crc32(name), i,
FURTHER_SENSORS_KEY, j))``; each is split into independent children for
process noise, detection draws, measurement noise and clutter. So a run is
the same whether generated alone or inside a Monte Carlo set, changing the
clutter law leaves the target noise as it was, a one-sensor scenario draws
what it drew before scenarios had several sensors, and a sensor's draws do
not depend on the other sensors.

A sensor of asynchronous reports (`nnda.data.scenario.Sensor.reports`)
draws the same four streams and one more, its report times
(`report_stream`): each (window, target) row and each clutter point gets a
time uniform in its window (t_{k-1}, t_k], cut to after the target's start
(and t > 0), and its measurement is of the target's noise-free position at
that time plus the window's process-noise perturbation (the jitter of the
window's truth row, which stands for the whole window). Truth rows stay at
the windows' ends, and a hull hides a ship from such a sensor as it stands
at the window's end (`nnda.data.occlusion`). A sweep sensor draws nothing from that stream, so every
sweep sensor's draws are what they were before report sensors existed.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from nnda.data.checks import MAX_DETECTIONS, check_clutter, check_size, target_warnings, whole_number
from nnda.data.clutter import clutter_counts, clutter_positions
from nnda.data.dataset import Dataset, Detections, Truth
from nnda.data.occlusion import hidden
from nnda.data.scenario import Clutter, Scenario
from nnda.data.sensor import cart_to_polar_at, in_coverage, in_coverage_polar, measure, polar_to_cart_at
from nnda.data.trajectory import evaluate

#: spawn-key entry under a run's root SeedSequence that leads to the streams of sensors 1, 2, ...
#: (the first sensor's four streams are the root's children 0-3)
FURTHER_SENSORS_KEY = 4
#: spawn-key entry under a sensor's root SeedSequence that leads to a report sensor's report-time stream
REPORT_TIMES_KEY = 5


@dataclass(frozen=True)
class Plan:
    """Noise-free truth of a scenario at its scan times; row arrays of shape (M,).

    Rows are (scan, target) pairs where the target exists, ordered by scan
    then target; ``sensor`` is the index of the sensor sweeping the row's
    scan. ``missed`` flags the scripted gaps; ``pd`` is each row's
    detection probability and ``length`` its target's hull length (m, 0 for
    a point; `nnda.data.occlusion`). ``scan_time`` and ``scan_sensor`` (n_scans,) are
    `Scenario.scan_schedule`; ``clutter_centre`` (n_sensors, 2) m is each
    sensor's square or Gaussian clutter centre. `of` refuses a clutter region
    that the coverage (almost) misses (`nnda.data.checks.check_clutter`).
    """

    scenario: Scenario
    scan: np.ndarray
    time: np.ndarray
    target_id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    missed: np.ndarray
    pd: np.ndarray
    length: np.ndarray
    sensor: np.ndarray
    scan_time: np.ndarray
    scan_sensor: np.ndarray
    clutter_centre: np.ndarray

    @classmethod
    def of(cls, scenario: Scenario) -> Plan:
        scan_time, scan_sensor = scenario.scan_schedule()
        sensor_pd = np.array([s.pd for s in scenario.sensors])
        rows = []
        for tid, target in enumerate(scenario.targets):
            local = scan_time - target.start_time_s
            alive = (local >= -1e-9) & (local <= target.duration_s + 1e-9)
            k = np.flatnonzero(alive) + 1
            st = evaluate(target, np.clip(local[alive], 0.0, target.duration_s))
            pd = sensor_pd[scan_sensor[k - 1]] if target.pd is None else np.full(k.size, target.pd)
            rows.append((k, np.full(k.size, tid), st.x, st.y, st.vx, st.vy, np.isin(k, target.missed_scans), pd))
        cols = [np.concatenate(c) for c in zip(*rows)]
        order = np.lexsort((cols[1], cols[0]))
        scan, tid, x, y, vx, vy, missed, pd = (c[order] for c in cols)
        lengths = np.array([t.length_m or 0.0 for t in scenario.targets])
        sensor = scan_sensor[scan - 1]
        centres = np.array([_clutter_centre(s.clutter, x[sensor == j], y[sensor == j])
                            for j, s in enumerate(scenario.sensors)])
        check_clutter(scenario, centres)
        return cls(scenario, scan.astype(np.int32), scan_time[scan - 1], tid.astype(np.int32),
                   x, y, vx, vy, missed, pd, lengths[tid], sensor, scan_time, scan_sensor, centres)


def _clutter_centre(clutter: Clutter, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Square: centre of the noise-free bounding box; Gaussian: mean position; (2,) m.

    ``x``, ``y`` are the noise-free target positions at the sensor's sweeps.
    """
    if clutter.centre_m is not None:
        return np.asarray(clutter.centre_m, dtype=float)
    if x.size == 0:
        return np.zeros(2)
    if clutter.law == "gaussian":
        return np.array([x.mean(), y.mean()])
    return np.array([(x.min() + x.max()) / 2, (y.min() + y.max()) / 2])


def _sensor_key(scenario: Scenario, run: int, sensor: int) -> tuple[int, ...]:
    """Spawn key of one sensor's root SeedSequence in one run (module docstring)."""
    key = zlib.crc32(scenario.name.encode())
    return (key, run) if sensor == 0 else (key, run, FURTHER_SENSORS_KEY, sensor)


def run_streams(scenario: Scenario, seed: int, run: int, sensor: int = 0) -> list[np.random.Generator]:
    """Independent generators (process noise, detection, measurement, clutter) of one sensor in one run."""
    root = np.random.SeedSequence(seed, spawn_key=_sensor_key(scenario, run, sensor))
    return [np.random.default_rng(child) for child in root.spawn(4)]


def report_stream(scenario: Scenario, seed: int, run: int, sensor: int) -> np.random.Generator:
    """The report-time generator of a report sensor in one run, independent of its `run_streams`."""
    spawn_key = (*_sensor_key(scenario, run, sensor), REPORT_TIMES_KEY)
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=spawn_key))


def _in_windows(end: np.ndarray, start: np.ndarray, g: np.random.Generator) -> np.ndarray:
    """Times (s) uniform in (start, end] (shapes (n,)), one draw of ``g`` each; ``end`` itself where start >= end.

    Rounding never puts a time on ``start`` (the previous window's end, which belongs to that window)."""
    t = end - g.random(end.size) * (end - start)
    return np.minimum(np.maximum(t, np.nextafter(start, np.inf)), end)


def _report_times(plan: Plan, sensor: int, rows: np.ndarray, clutter_scans: np.ndarray,
                  g: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) of a report sensor's plan ``rows`` and clutter points (their scans ``clutter_scans``), shapes
    (rows.size,) and (clutter_scans.size,): uniform in their windows (t_{k-1}, t_k], a row's after its
    target's start; the first window opens at max(0, t_1 - scan_period_s). ``g``: rows first, then clutter."""
    sweeps = np.flatnonzero(plan.scan_sensor == sensor)
    ends = plan.scan_time[sweeps]
    first = max(0.0, float(ends[0]) - plan.scenario.sensors[sensor].scan_period_s)
    opens = np.concatenate([[first], ends[:-1]])
    born = np.array([t.start_time_s for t in plan.scenario.targets])[plan.target_id[rows]]
    row_end = plan.time[rows]
    row_open = np.minimum(np.maximum(opens[np.searchsorted(sweeps, plan.scan[rows] - 1)], born), row_end)
    clutter_window = np.searchsorted(sweeps, clutter_scans - 1)
    return _in_windows(row_end, row_open, g), _in_windows(ends[clutter_window], opens[clutter_window], g)


def _positions_at(scenario: Scenario, target_id: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free positions (x, y in m, shapes (n,)) of targets ``target_id`` at scenario times ``time`` (s), each
    inside its target's life."""
    x, y = np.empty(time.size), np.empty(time.size)
    for tid in np.unique(target_id):
        at = target_id == tid
        target = scenario.targets[tid]
        state = evaluate(target, np.clip(time[at] - target.start_time_s, 0.0, target.duration_s))
        x[at], y[at] = state.x, state.y
    return x, y


def realise(plan: Plan, seed: int, run: int) -> Dataset:
    """Draw one run of a planned scenario."""
    sc = plan.scenario
    jitter = sc.process_noise.model == "jitter" and sc.process_noise.sigma_accel > 0
    x, y, detected = np.empty_like(plan.x), np.empty_like(plan.y), np.empty(plan.x.size, dtype=bool)
    parts = []  # per sensor: (scan, time, range, azimuth, x, y, target_id, sensor) of its detections, unsorted
    for j, sensor in enumerate(sc.sensors):
        g_process, g_detect, g_measure, g_clutter = run_streams(sc, seed, run, j)
        rows = np.flatnonzero(plan.sensor == j)
        xj, yj = plan.x[rows], plan.y[rows]
        if jitter:
            scale = 0.5 * sensor.scan_period_s**2 * sc.process_noise.sigma_accel  # (T^2 / 2) sigma_accel, m
            w = g_process.standard_normal((2, rows.size)) * scale
            xj, yj = xj + w[0], yj + w[1]
        x[rows], y[rows] = xj, yj
        sweeps = np.flatnonzero(plan.scan_sensor == j) + 1
        counts = clutter_counts(sensor.clutter, sweeps.size, g_clutter)
        clutter_scan = np.repeat(sweeps, counts)
        at_x, at_y, t_row, t_clutter = xj, yj, plan.time[rows], plan.scan_time[clutter_scan - 1]  # seen where, when
        if sensor.reports:
            t_row, t_clutter = _report_times(plan, j, rows, clutter_scan, report_stream(sc, seed, run, j))
            at_x, at_y = _positions_at(sc, plan.target_id[rows], t_row)
            if jitter:  # the window's perturbation, as its truth row's
                at_x, at_y = at_x + w[0], at_y + w[1]

        za, zb = measure(sensor, at_x, at_y, g_measure)
        covered = in_coverage(sensor, za, zb) if sensor.kind == "position" else in_coverage_polar(sensor, za, zb)
        seen = ~plan.missed[rows] & (g_detect.random(rows.size) < plan.pd[rows]) & covered
        if plan.length.any():  # ships hide the shorter ships behind them (nnda.data.occlusion)
            seen &= ~hidden(sensor.position, plan.scan[rows], xj, yj, plan.length[rows])
        detected[rows] = seen

        cx, cy = clutter_positions(sensor.clutter, sensor, plan.clutter_centre[j], int(counts.sum()), g_clutter)
        scan = np.concatenate([plan.scan[rows][seen], clutter_scan])
        time = np.concatenate([t_row[seen], t_clutter])
        tid = np.concatenate([plan.target_id[rows][seen], np.full(cx.size, -1, dtype=np.int32)])
        if sensor.kind == "position":
            mx, my = np.concatenate([za[seen], cx]), np.concatenate([zb[seen], cy])
            r, az = cart_to_polar_at(sensor.position, mx, my)
        else:
            cr, caz = cart_to_polar_at(sensor.position, cx, cy)
            r, az = np.concatenate([za[seen], cr]), np.concatenate([zb[seen], caz])
            mx, my = polar_to_cart_at(sensor.position, r, az)
        parts.append((scan, time, r, az, mx, my, tid, np.full(scan.size, j, dtype=np.int32)))

    scan, time, r, az, mx, my, tid, sensor_of = (np.concatenate(c) for c in zip(*parts))
    by_time = np.array([s.reports for s in sc.sensors])[sensor_of]
    order = np.lexsort((az, np.where(by_time, time, az), scan))  # a sweep's rows by azimuth, reports by time
    scan, time, r, az, mx, my, tid, sensor_of = (a[order] for a in (scan, time, r, az, mx, my, tid, sensor_of))
    scan = scan.astype(np.int32)
    detections = Detections(scan, time, r, az, mx, my, tid < 0, tid, sensor_of)
    truth = Truth(plan.scan, plan.time, plan.target_id, x, y, plan.vx, plan.vy, detected)
    return Dataset(sc, seed, run, detections, truth)


def generate(scenario: Scenario, seed: int | None = None, run: int = 0,
             max_detections: int = MAX_DETECTIONS) -> Dataset:
    """One run of ``scenario``; ``seed`` defaults to the scenario's own.

    Refused before anything is drawn (ConfigError): a seed or run that is
    not a whole number >= 0, a scenario whose dataset could hold more than
    ``max_detections`` detections (`nnda.data.checks.check_size`), a clutter
    region outside its sensor's coverage (`Plan.of`).
    """
    return next(generate_runs(scenario, [run], seed, max_detections))


def generate_runs(scenario: Scenario, runs: Iterable[int], seed: int | None = None,
                  max_detections: int = MAX_DETECTIONS) -> Iterator[Dataset]:
    """Runs of one scenario sharing the noise-free plan (a Monte Carlo set); refusals as `generate`."""
    seed = whole_number(scenario.seed if seed is None else seed, "seed")
    check_size(scenario, max_detections)
    plan = Plan.of(scenario)
    for run in runs:
        yield realise(plan, seed, whole_number(run, "run"))


def check_scenario(scenario: Scenario, max_detections: int = MAX_DETECTIONS) -> list[str]:
    """Every check of ``scenario`` short of generating it; returns its plausibility warnings.

    Raises what `generate` raises before drawing (size above
    ``max_detections``, clutter outside the coverage); the returned lines
    (`nnda.data.checks.target_warnings`) name implausible targets, for a
    command to print.
    """
    check_size(scenario, max_detections)
    plan = Plan.of(scenario)
    return target_warnings(scenario, plan.target_id, plan.sensor, plan.x, plan.y)
