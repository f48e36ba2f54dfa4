"""Scoring at scale: `nnda.study.metrics.run_metrics` on hundreds to thousands of targets.

A surface radar of 250 km range, n aircraft spread over it (70-200 m/s,
half of them turning), 100 clutter points a scan, 30 scans of 10 s; gnn
tracks each run once (with ``lifecycle.v_max`` raised to 250 m/s), then the
run is scored twice in this process: with GOSPA's and OSPA's assignments
solved over the pairs closer than the cut-off only (what nnda does above
`nnda.study.gospa.DENSE_MAX_PAIRS` truth x estimate pairs a scan) and as one
dense n x m problem every scan (the reference). Prints the seconds of each,
their ratio, the tracking time beside them, and checks the two give the
same measures (1e-9 relative).

    .venv/bin/python benchmarks/bench_scoring.py [--targets 200 1000 2000]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np

import nnda.study.gospa as gospa_module
from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.study.metrics import run_metrics
from nnda.tracking.registry import make_tracker

SCANS, PERIOD_S, RANGE_M = 30, 10.0, 250_000.0


def scene(n: int, seed: int = 0, scans: int = SCANS) -> Scenario:
    """n aircraft over a 250 km radar's coverage, 100 clutter points a scan, ``scans`` scans of 10 s."""
    rng = np.random.default_rng(seed)
    radar = Sensor(scan_period_s=PERIOD_S, max_range_m=RANGE_M, min_range_m=5_000.0, sigma_range_m=50.0,
                   sigma_azimuth_mrad=1.5, pd=0.9, clutter=Clutter(law="annulus", count=100))
    targets = []
    for i in range(n):
        r, b = rng.uniform(30_000, 200_000), rng.uniform(0, 2 * np.pi)
        turn = {"normal_accel": float(rng.uniform(-2, 2))} if i % 2 else {}
        targets.append(Target(name=f"a{i}", x_m=r * np.sin(b), y_m=r * np.cos(b),
                              heading_deg=float(rng.uniform(0, 360)), speed_m_s=float(rng.uniform(70, 200)),
                              segments=[Segment(duration_s=scans * PERIOD_S, **turn)]))
    return Scenario(name=f"aircraft{n}", duration_s=scans * PERIOD_S, targets=targets, sensors=[radar])


def scored(dataset, outputs, dense: bool) -> tuple[float, dict]:
    """Seconds of one `run_metrics` call and its values; ``dense``: every scan as one dense problem."""
    saved = gospa_module.DENSE_MAX_PAIRS
    gospa_module.DENSE_MAX_PAIRS = math.inf if dense else saved
    try:
        start = time.perf_counter()
        values = run_metrics(dataset, outputs, 1_000.0, "position").values
        return time.perf_counter() - start, values
    finally:
        gospa_module.DENSE_MAX_PAIRS = saved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--targets", type=int, nargs="+", default=[200, 1_000, 2_000])
    args = parser.parse_args()
    print(f"{'targets':>8s}{'tracking s':>12s}{'scoring s':>11s}{'dense s':>9s}{'ratio':>7s}  same measures")
    for n in args.targets:
        dataset = generate(scene(n))
        tracker = make_tracker("gnn", dataset.scenario.sensors, {"lifecycle": {"v_max": 250.0}})
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            outputs = [tracker.step(scan) for scan in dataset.scans()]
        tracking = time.perf_counter() - start
        scored(dataset, outputs, dense=False)  # warm: the compiled kernels load once
        fast, values = scored(dataset, outputs, dense=False)
        slow, reference = scored(dataset, outputs, dense=True)
        same = all(np.isclose(values[k], reference[k], rtol=1e-9, atol=0.0, equal_nan=True) for k in values)
        print(f"{n:8d}{tracking:12.2f}{fast:11.2f}{slow:9.2f}{slow / fast:7.1f}  {same}")


if __name__ == "__main__":
    main()
