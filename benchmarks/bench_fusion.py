"""Fusion of local GM-PHD filters: ms per scan of each fusion tracker, the local filters and the rule.

Every scan of a fusion tracker updates one local GM-PHD (the sweeping radar's) and then fuses the local
intensities at the centre (`nnda.tracking.phd.fusion`). Printed per tracker, in one process: the mean ms
per scan in all, in the local filter's update, and in the fusion rule (the rest: prediction of the other
local intensity, weights, the merge, the centre's ids, extraction), with the rule's share of the local
filters' own cost; ``fusion-central`` (one GM-PHD on both radars) has no rule. Two scenes: the harbour
preset (5 ships, about 2 clutter points per sweep) and a crowded harbour (``--ships`` ships on straight
courses inside both sectors, ``--clutter`` clutter points per radar sweep).
Usage: python benchmarks/bench_fusion.py [--scans S] [--ships N] [--clutter C] [--repeat R]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Scenario, Segment, Target
from nnda.tracking.registry import make_tracker

NAMES = ("fusion-merge", "fusion-aa", "fusion-central")


def crowded(ships: int, clutter: int, duration_s: float) -> Scenario:
    """The harbour's radars with ``ships`` ships (seeded) on straight courses near the sectors' overlap."""
    rng = np.random.default_rng(16)
    harbour = PRESETS["harbour"]
    targets = [Target(name=f"ship{i}", x_m=float(x), y_m=float(y), heading_deg=float(h), speed_m_s=float(v),
                      segments=[Segment(duration_s=duration_s)])
               for i, (x, y, h, v) in enumerate(zip(rng.uniform(-1_500.0, 3_500.0, ships),
                                                    rng.uniform(1_500.0, 7_500.0, ships),
                                                    rng.uniform(0.0, 360.0, ships), rng.uniform(2.0, 8.0, ships)))]
    sensors = tuple(s.model_copy(update={"clutter": s.clutter.model_copy(update={"count": clutter})})
                    for s in harbour.sensors)
    return harbour.model_copy(update={"name": "crowded-harbour", "targets": targets, "sensors": sensors,
                                      "duration_s": duration_s})


def timed_run(name: str, dataset) -> tuple[float, float]:
    """(ms per scan in all, ms per scan in the local filters' updates) of one run of tracker ``name``."""
    tracker = make_tracker(name, dataset.scenario.sensors)
    local_s = [0.0]
    for f in getattr(tracker, "local", ()):
        step = f.step

        def clocked(scan, step=step):
            t0 = time.perf_counter()
            out = step(scan)
            local_s[0] += time.perf_counter() - t0
            return out

        f.step = clocked
    scans = list(dataset.scans())
    t0 = time.perf_counter()
    for scan in scans:
        tracker.step(scan)
    total = time.perf_counter() - t0
    local = local_s[0] if getattr(tracker, "local", None) else total
    return 1e3 * total / len(scans), 1e3 * local / len(scans)


def report(title: str, dataset, repeat: int) -> None:
    print(f"\n{title}: {dataset.n_scans} scans, {len(dataset.scenario.targets)} ships, "
          f"{len(dataset.detections.scan) / dataset.n_scans:.1f} contacts per scan")
    print(f"{'tracker':<16s}{'ms/scan':>10s}{'local':>10s}{'rule':>10s}{'rule/local':>12s}")
    for name in NAMES:
        total, local = min(timed_run(name, dataset) for _ in range(repeat))
        rule = total - local
        share = f"{rule / local:.2f}" if name != "fusion-central" else "-"
        print(f"{name:<16s}{total:10.3f}{local:10.3f}{(rule if name != 'fusion-central' else 0.0):10.3f}{share:>12s}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=200, help="scans (both radars) per scene")
    parser.add_argument("--ships", type=int, default=100, help="ships of the crowded scene")
    parser.add_argument("--clutter", type=int, default=50, help="clutter points per radar sweep, crowded scene")
    parser.add_argument("--repeat", type=int, default=3, help="runs per tracker; the fastest is kept")
    args = parser.parse_args()
    duration = max(1.0, float(args.scans // 2))  # two radars, one sweep each per second
    harbour = PRESETS["harbour"]
    report("harbour", generate(harbour.model_copy(update={"duration_s": min(duration, harbour.duration_s)}), seed=1),
           args.repeat)
    report("crowded harbour", generate(crowded(args.ships, args.clutter, duration), seed=1), args.repeat)


if __name__ == "__main__":
    main()
