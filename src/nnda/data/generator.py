"""Scenario generator: noise-free truth + process noise + measurement noise + clutter + gaps.

Spec §3.2. The noise-free part (trajectories sampled at the scan times) is
computed once per scenario in a `Plan`; each run then draws its own noise,
detections and clutter, vectorised over all scans and targets.

Random streams: run ``i`` of seed ``s`` of scenario ``name`` uses
``SeedSequence(s, spawn_key=(crc32(name), i))``, split into independent
children for process noise, detection draws, measurement noise and clutter.
So a run is the same whether generated alone or inside a Monte Carlo set,
and changing the clutter law leaves the target noise as it was.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from nnda.data.clutter import clutter_counts, clutter_positions
from nnda.data.dataset import Dataset, Detections, Truth
from nnda.data.scenario import Scenario
from nnda.data.sensor import cart_to_polar, in_coverage, measure, polar_to_cart
from nnda.data.trajectory import evaluate


@dataclass(frozen=True)
class Plan:
    """Noise-free truth of a scenario at its scan times; arrays of shape (M,).

    Rows are (scan, target) pairs where the target exists, ordered by scan
    then target. ``missed`` flags the scripted gaps; ``pd`` is each row's
    detection probability.
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
    clutter_centre: np.ndarray  # (2,) m

    @classmethod
    def of(cls, scenario: Scenario) -> Plan:
        period = scenario.sensor.scan_period_s
        scan_times = period * np.arange(1, scenario.n_scans + 1)
        rows = []
        for tid, target in enumerate(scenario.targets):
            local = scan_times - target.start_time_s
            alive = (local >= -1e-9) & (local <= target.duration_s + 1e-9)
            k = np.flatnonzero(alive) + 1
            st = evaluate(target, np.clip(local[alive], 0.0, target.duration_s))
            pd = scenario.sensor.pd if target.pd is None else target.pd
            rows.append((k, np.full(k.size, tid), st.x, st.y, st.vx, st.vy,
                         np.isin(k, target.missed_scans), np.full(k.size, pd)))
        cols = [np.concatenate(c) for c in zip(*rows)]
        order = np.lexsort((cols[1], cols[0]))
        scan, tid, x, y, vx, vy, missed, pd = (c[order] for c in cols)
        return cls(scenario, scan.astype(np.int32), scan * period, tid.astype(np.int32),
                   x, y, vx, vy, missed, pd, _clutter_centre(scenario, x, y))


def _clutter_centre(scenario: Scenario, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Square: centre of the noise-free bounding box; Gaussian: mean position (spec §14)."""
    if scenario.clutter.centre_m is not None:
        return np.asarray(scenario.clutter.centre_m, dtype=float)
    if x.size == 0:
        return np.zeros(2)
    if scenario.clutter.law == "gaussian":
        return np.array([x.mean(), y.mean()])
    return np.array([(x.min() + x.max()) / 2, (y.min() + y.max()) / 2])


def run_streams(scenario: Scenario, seed: int, run: int) -> list[np.random.Generator]:
    """Independent generators (process noise, detection, measurement, clutter) of one run."""
    key = zlib.crc32(scenario.name.encode())
    root = np.random.SeedSequence(seed, spawn_key=(key, run))
    return [np.random.default_rng(child) for child in root.spawn(4)]


def realise(plan: Plan, seed: int, run: int) -> Dataset:
    """Draw one run of a planned scenario."""
    sc = plan.scenario
    sensor, period = sc.sensor, sc.sensor.scan_period_s
    g_process, g_detect, g_measure, g_clutter = run_streams(sc, seed, run)

    x, y = plan.x, plan.y
    if sc.process_noise.model == "jitter" and sc.process_noise.sigma_accel > 0:
        w = g_process.standard_normal((2, x.size)) * (0.5 * period**2 * sc.process_noise.sigma_accel)
        x, y = x + w[0], y + w[1]

    r, az = measure(sensor, x, y, g_measure)
    detected = ~plan.missed & (g_detect.random(x.size) < plan.pd) & in_coverage(sensor, r)

    counts = clutter_counts(sc.clutter, sc.n_scans, g_clutter)
    cx, cy = clutter_positions(sc.clutter, sensor, plan.clutter_centre, int(counts.sum()), g_clutter)
    cr, caz = cart_to_polar(cx, cy)

    scan = np.concatenate([plan.scan[detected], np.repeat(np.arange(1, sc.n_scans + 1), counts)])
    rng_ = np.concatenate([r[detected], cr])
    azim = np.concatenate([az[detected], caz])
    tid = np.concatenate([plan.target_id[detected], np.full(cr.size, -1, dtype=np.int32)])
    order = np.lexsort((azim, scan))
    scan, rng_, azim, tid = scan[order].astype(np.int32), rng_[order], azim[order], tid[order]
    mx, my = polar_to_cart(rng_, azim)
    detections = Detections(scan, scan * period, rng_, azim, mx, my, tid < 0, tid)
    truth = Truth(plan.scan, plan.time, plan.target_id, x, y, plan.vx, plan.vy, detected)
    return Dataset(sc, seed, run, detections, truth)


def generate(scenario: Scenario, seed: int | None = None, run: int = 0) -> Dataset:
    """One run of ``scenario``; ``seed`` defaults to the scenario's own."""
    return realise(Plan.of(scenario), scenario.seed if seed is None else seed, run)


def generate_runs(scenario: Scenario, runs: Iterable[int], seed: int | None = None) -> Iterator[Dataset]:
    """Runs of one scenario sharing the noise-free plan (a Monte Carlo set)."""
    plan = Plan.of(scenario)
    seed = scenario.seed if seed is None else seed
    for run in runs:
        yield realise(plan, seed, run)
