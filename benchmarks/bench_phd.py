"""PHD tracker speed: ms per scan on S1-S6 and at 10 / 100 / 1,000 clutter, against Stone Soup.

Part 1: ``gmphd``, ``ekphd``, ``ukphd``, ``cphd`` and Stone Soup's GM-PHD (``stonesoup-gmphd``, when the
peers extra is installed) on S1-S6 (100 clutter points per scan), mean ms per scan, and the speed ratio
Stone Soup / ours over the same scans, in one process. Stone Soup takes about half a second per scan, so it
runs the first ``--peer-scans`` scans of each scenario only (ours are timed over those scans too for the
ratio). Part 2: S6's six targets with 10, 100 and 1,000 clutter points per scan over ``--scans`` scans:
ms per scan, the CPHD / EK-PHD time ratio, the largest mixture held, and the peak memory a run allocates
(tracemalloc, in a separate untimed run).
Usage: python benchmarks/bench_phd.py [--runs N] [--repeat R] [--scans S] [--peer-scans P] [--no-peer]
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.errors import ConfigError
from nnda.tracking.registry import make_tracker

OURS = ("gmphd", "ekphd", "ukphd", "cphd")
PEER = "stonesoup-gmphd"
SCENARIOS = ("S1", "S2", "S3", "S4", "S5", "S6")


def time_run(name: str, dataset, scans: int) -> tuple[np.ndarray, int]:
    """Seconds per scan of one tracker over the first ``scans`` scans, and the largest mixture it held."""
    tracker = make_tracker(name, dataset.scenario.sensor)
    times, biggest = [], 0
    for scan in list(dataset.scans())[:scans]:
        t0 = time.perf_counter()
        tracker.step(scan)
        times.append(time.perf_counter() - t0)
        mixture = getattr(tracker, "mixture", None)
        biggest = max(biggest, len(mixture) if mixture is not None else len(tracker.tracker.gaussian_mixture))
    return np.array(times), biggest


def best_of(name: str, dataset, scans: int, repeat: int) -> tuple[np.ndarray, int]:
    """Each scan's fastest of ``repeat`` runs (a busy machine adds time, never removes it)."""
    runs = [time_run(name, dataset, scans) for _ in range(repeat)]
    return np.min([t for t, _ in runs], axis=0), runs[0][1]


def peak_mib(name: str, dataset, scans: int) -> float:
    """Peak memory (MiB) allocated while one tracker runs ``scans`` scans (tracemalloc; not timed)."""
    tracker = make_tracker(name, dataset.scenario.sensor)
    todo = list(dataset.scans())[:scans]
    tracemalloc.start()
    tracemalloc.reset_peak()
    for scan in todo:
        tracker.step(scan)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def part1(names: list[str], runs: int, repeat: int, peer_scans: int) -> None:
    print(f"\nms per scan on S1-S6 (100 clutter per scan; {runs} run(s), each scan's best of {repeat}); "
          f"x = {PEER} time / ours on the first {peer_scans} scans, same process")
    print(f"{'tracker':<17s}" + "".join(f"{s:>16s}" for s in SCENARIOS) + f"{'all':>16s}")
    data = {sc: [generate(PRESETS[sc], seed=run) for run in range(runs)] for sc in SCENARIOS}
    times = {}
    for name in names:
        for sc in SCENARIOS:
            scans = peer_scans if name == PEER else 10**9
            times[name, sc] = [best_of(name, ds, scans, 1 if name == PEER else repeat)[0] for ds in data[sc]]
    for name in names:
        cells, every, ratios = [], [], []
        for sc in SCENARIOS:
            t = np.concatenate(times[name, sc]) * 1e3
            every.append(t)
            cell = f"{t.mean():.2f}"
            if PEER in names and name != PEER:
                peer = np.concatenate(times[PEER, sc]).mean()
                ours = np.concatenate([r[:peer_scans] for r in times[name, sc]]).mean()
                ratios.append(peer / ours)
                cell += f" ({ratios[-1]:.0f}x)"
            cells.append(cell)
        allt = np.concatenate(every)
        ratio = f" ({np.exp(np.mean(np.log(ratios))):.0f}x)" if ratios else ""
        print(f"{name:<17s}" + "".join(f"{c:>16s}" for c in cells) + f"{f'{allt.mean():.2f}{ratio}':>16s}")
    if "cphd" in names and "ekphd" in names:
        ek = np.concatenate([np.concatenate(times["ekphd", sc]) for sc in SCENARIOS]).mean()
        cp = np.concatenate([np.concatenate(times["cphd", sc]) for sc in SCENARIOS]).mean()
        print(f"cphd / ekphd time on S1-S6: {cp / ek:.2f}")


def part2(names: list[str], scans: int, peer_scans: int, repeat: int) -> None:
    print(f"\nS6 (6 targets) with more clutter, {scans} scans (Stone Soup: {peer_scans} scans, and not at 1,000): "
          "ms per scan / largest mixture J / peak MiB")
    counts = (10, 100, 1_000)
    print(f"{'tracker':<17s}" + "".join(f"{f'clutter {c}':>26s}" for c in counts))
    settings = {c: generate(PRESETS["S6"].model_copy(update={
        "duration_s": 2.0 * scans, "clutter": PRESETS["S6"].clutter.model_copy(update={"count": c})}), seed=1)
        for c in counts}
    mean = {}
    for name in names:
        cells = []
        for c, ds in settings.items():
            if name == PEER and c > 100:
                cells.append(f"{'-':>26s}")
                continue
            n = peer_scans if name == PEER else scans
            t, biggest = best_of(name, ds, n, 1 if name == PEER else repeat)
            mean[name, c] = t.mean()
            cells.append(f"{f'{t.mean() * 1e3:.2f} / {biggest} / {peak_mib(name, ds, n):.1f}':>26s}")
        print(f"{name:<17s}" + "".join(cells))
    if "cphd" in names and "ekphd" in names:
        print("cphd / ekphd time: " + ", ".join(f"{c} clutter {mean['cphd', c] / mean['ekphd', c]:.2f}"
                                                for c in counts))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1, help="runs (seeds) per scenario in part 1")
    parser.add_argument("--repeat", type=int, default=3, help="time our trackers this many times, keep each "
                        "scan's fastest")
    parser.add_argument("--scans", type=int, default=40, help="scans per clutter setting in part 2")
    parser.add_argument("--peer-scans", type=int, default=20, help="scans Stone Soup runs per scenario")
    parser.add_argument("--no-peer", action="store_true", help="leave Stone Soup out")
    args = parser.parse_args()
    names = list(OURS)
    if not args.no_peer:
        try:
            make_tracker(PEER, PRESETS["S1"].sensor)
            names.append(PEER)
        except ConfigError as exc:
            print(f"note: {PEER} is skipped: {exc}")
    part1(names, args.runs, args.repeat, args.peer_scans)
    part2(names, args.scans, args.peer_scans, args.repeat)


if __name__ == "__main__":
    main()
