"""Generation speed: detections per second for a large Monte Carlo set.

Prints, for S6 x RUNS runs: in-memory generation on one process and on two
processes, writing a collection to disk, and a per-scan Python-loop
reference generator run in the same process (the ratio shows what the
vectorised generator buys). Usage: python benchmarks/bench_generate.py [RUNS]
"""

from __future__ import annotations

import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from nnda.data.dataset import write_collection
from nnda.data.generator import Plan, generate_runs
from nnda.data.presets import PRESETS

SCENARIO = PRESETS["S6"]
SEED = 1


def _count(runs: range) -> int:
    return sum(ds.detections.scan.size for ds in generate_runs(SCENARIO, runs, SEED))


def reference_loop(runs: int) -> int:
    """A plain generator: one Python iteration per scan and per target (the reference)."""
    plan = Plan.of(SCENARIO)
    sensor = SCENARIO.sensor
    rng = np.random.default_rng(SEED)
    n = 0
    for _ in range(runs):
        for k in range(1, SCENARIO.n_scans + 1):
            contacts = []
            for row in np.flatnonzero(plan.scan == k):
                if plan.missed[row]:
                    continue
                r = np.hypot(plan.x[row], plan.y[row]) + rng.normal(0, sensor.sigma_range_m)
                az = np.arctan2(plan.x[row], plan.y[row]) + rng.normal(0, sensor.sigma_azimuth_rad)
                contacts.append((r, az))
            targets_seen = len(contacts)
            while len(contacts) < targets_seen + SCENARIO.clutter.count:
                x, y = plan.clutter_centre[0] + rng.uniform(-0.5, 0.5, 2) * SCENARIO.clutter.side_m
                r = np.hypot(x, y)
                if sensor.min_range_m <= r <= sensor.max_range_m:
                    contacts.append((r, np.arctan2(x, y)))
            contacts.sort(key=lambda c: c[1])
            n += len(contacts)
    return n


def _rate(label: str, fn, *args) -> float:
    t0 = time.perf_counter()
    n = fn(*args)
    dt = time.perf_counter() - t0
    print(f"{label:<56s} {n:>11,d} detections in {dt:7.2f} s = {n / dt:>12,.0f} detections/s")
    return n / dt


def main(runs: int = 1000) -> None:
    print(f"S6 ({len(SCENARIO.targets)} targets, {SCENARIO.n_scans} scans, "
          f"{SCENARIO.clutter.count} clutter/scan) x {runs} runs")
    ref = _rate("reference: per-scan Python loop (20 runs)", reference_loop, 20)
    one = _rate("vectorised, 1 process, in memory", _count, range(runs))
    half = runs // 2
    with ProcessPoolExecutor(2) as pool:
        pool.submit(_count, range(1)).result()  # start the workers before timing
        t0 = time.perf_counter()
        n = sum(pool.map(_count, [range(half), range(half, runs)]))
        dt = time.perf_counter() - t0
    two = n / dt
    print(f"{'vectorised, 2 processes, in memory':<56s} {n:>11,d} detections in {dt:7.2f} s "
          f"= {two:>12,.0f} detections/s")
    disk_runs = max(1, runs // 10)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        members = ((f"run-{d.run:04d}", d) for d in generate_runs(SCENARIO, range(disk_runs), SEED))
        write_collection(members, Path(tmp) / "mc", "bench")
        dt = time.perf_counter() - t0
    n_disk = _count(range(disk_runs))
    print(f"{f'vectorised, 1 process, written as Parquet ({disk_runs} runs)':<56s} {n_disk:>11,d} detections in "
          f"{dt:7.2f} s = {n_disk / dt:>12,.0f} detections/s")
    print(f"speed-up over the reference loop: 1 process {one / ref:.0f}x, 2 processes {two / ref:.0f}x")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
