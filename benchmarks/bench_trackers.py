"""Tracker speed: ms per scan on S1-S6 and a scaling table (issue 6).

Part 1: every registered tracker on S1-S6 (100 clutter points per scan),
mean and 95th-percentile wall time per scan, with the GNN as the reference
run in the same process (ratio column). Part 2: the same trackers as clutter
grows 100 -> 1,000 -> 10,000 per scan (S6's six targets) and as targets grow
6 -> 50 -> 200 (100 clutter), over SCALING_SCANS scans each (``--scans``); a
tracker is dropped from the bigger settings once it passes 10 s per scan.

The neural tracker needs a model: pass ``--model PATH`` (a file written by
``nnda train``), once per model to time (e.g. the seed-feature and the
IMM-extended one: rows ``nn:kinematic-3``, ``nn:imm-innovation-9``); without
it the neural tracker is skipped with a note.
Usage: python benchmarks/bench_trackers.py [--model PATH]... [--runs N] [--repeat R] [--scans N] [--no-scaling]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.models.scorer import load_model
from nnda.tracking.registry import TRACKERS, make_tracker

SCALING_SCANS = 15
GIVE_UP_S = 10.0


def params_for(name: str, model: str | None) -> dict | None:
    if name == "nn":
        return None if model is None else {"model": model}
    return {}


def time_run(name: str, params: dict, dataset, give_up: float = math.inf, outputs: list | None = None) -> np.ndarray:
    """Seconds per scan of one tracker over one dataset (stops early past ``give_up`` s/scan);
    the tracker's outputs are appended to ``outputs`` when given."""
    tracker = make_tracker(name, dataset.scenario.sensor, params)
    times = []
    for scan in dataset.scans():
        t0 = time.perf_counter()
        out = tracker.step(scan)
        times.append(time.perf_counter() - t0)
        if outputs is not None:
            outputs.append(out)
        if times[-1] > give_up:
            break
    return np.array(times)


def many_targets(n: int, seed: int, scans: int) -> Scenario:
    """n targets spread over the coverage, 70-200 m/s, half of them turning, 100 clutter points."""
    rng = np.random.default_rng(seed)
    targets = []
    for i in range(n):
        r, b = rng.uniform(9_000, 24_000), rng.uniform(0, 2 * np.pi)
        speed = rng.uniform(70, 200)
        turn = {"normal_accel": float(rng.uniform(-5, 5))} if i % 2 else {}
        targets.append(Target(name=f"t{i}", x_m=r * np.sin(b), y_m=r * np.cos(b),
                              heading_deg=float(rng.uniform(0, 360)), speed_m_s=speed,
                              segments=[Segment(duration_s=2.0 * scans, **turn)]))
    return Scenario(name=f"targets{n}", duration_s=2.0 * scans, targets=targets,
                    clutter=Clutter(law="annulus", count=100))


def best_of(name: str, params: dict, dataset, repeat: int) -> np.ndarray:
    """Seconds per scan, each scan's fastest of ``repeat`` runs over the same dataset: on a machine
    shared with other work, closer to what the code costs than one run's times."""
    return np.min([time_run(name, params, dataset) for _ in range(repeat)], axis=0)


def entries(models: list[str]) -> list[tuple[str, str, dict]]:
    """(row label, tracker kind, params) of every tracker to time: gnn first (the reference), then the
    other registered kinds, the neural one once per model (labelled with the model's feature set)."""
    rows = [("gnn", "gnn", {})]
    for kind in TRACKERS:
        if kind == "nn":
            rows += [(f"nn:{load_model(m).features.name}", "nn", params_for("nn", m)) for m in models]
        elif kind != "gnn":
            rows.append((kind, kind, params_for(kind, None)))
    return rows


def part1(rows: list[tuple[str, str, dict]], runs: int, repeat: int = 1) -> None:
    best = f", each scan's best of {repeat} repeats" if repeat > 1 else ""
    print(f"\nms per scan on S1-S6 ({runs} run(s) each{best}; ratio = tracker / gnn, same process)")
    print(f"{'tracker':<20s}" + "".join(f"{s:>16s}" for s in ("S1", "S2", "S3", "S4", "S5", "S6")) + f"{'all':>16s}")
    ref = None
    for label, kind, params in rows:
        per, every = [], []
        for sc in ("S1", "S2", "S3", "S4", "S5", "S6"):
            t = np.concatenate([best_of(kind, params, generate(PRESETS[sc], seed=run), repeat)
                                for run in range(runs)]) * 1e3
            per.append(f"{t.mean():7.2f} p95 {np.percentile(t, 95):5.2f}")
            every.append(t)
        allt = np.concatenate(every)
        ref = allt.mean() if label == "gnn" else ref
        ratio = f"  ({allt.mean() / ref:.2f}x gnn)" if ref else ""
        print(f"{label:<20s}" + "".join(f"{p:>16s}" for p in per) + f"{allt.mean():9.2f}{ratio}")


def scaling_settings(scans: int = SCALING_SCANS) -> list[tuple[str, int, Scenario]]:
    """(axis, value, scenario) of the scaling runs: S6 with 100, 1,000 and 10,000 clutter points per
    scan, then 6, 50 and 200 targets with 100 clutter points; ``scans`` scans each."""
    settings = [("clutter", c, PRESETS["S6"].model_copy(update={
                    "duration_s": 2.0 * scans, "clutter": PRESETS["S6"].clutter.model_copy(update={"count": c})}))
                for c in (100, 1_000, 10_000)]
    return settings + [("targets", n, many_targets(n, seed=n, scans=scans)) for n in (6, 50, 200)]


def part2(rows: list[tuple[str, str, dict]], scans: int = SCALING_SCANS) -> None:
    settings = scaling_settings(scans)
    print(f"\nscaling: mean ms per scan over {scans} scans (x = stopped: over {GIVE_UP_S:.0f} s/scan before)")
    print(f"{'tracker':<20s}" + "".join(f"{k}={v:<9d}" for k, v, _ in settings))
    for label, kind, params in rows:
        row, stopped = [], {"clutter": False, "targets": False}
        for axis, _, scenario in settings:
            if stopped[axis]:
                row.append(f"{'x':>17s}")
                continue
            t = time_run(kind, params, generate(scenario, seed=1), GIVE_UP_S)
            stopped[axis] = t.max() > GIVE_UP_S
            row.append(f"{t.mean() * 1e3:>17.2f}")
        print(f"{label:<20s}" + "".join(row))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", action="append", default=[],
                        help="model file for the neural tracker (repeat to time several)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=1, help="time each S1-S6 run this many times and keep "
                        "each scan's fastest (for a busy machine)")
    parser.add_argument("--scans", type=int, default=SCALING_SCANS, help="scans per scaling setting")
    parser.add_argument("--no-scaling", action="store_true")
    args = parser.parse_args()
    rows = entries(args.model)
    if not args.model:
        print("note: the neural tracker is skipped (give --model PATH, a file written by `nnda train`)")
    part1(rows, args.runs, args.repeat)
    if not args.no_scaling:
        part2(rows, args.scans)


if __name__ == "__main__":
    main()
