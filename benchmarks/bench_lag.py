"""The fixed-lag output (`nnda.tracking.lag.FixedLag`): what it buys and what it costs.

For each tracker (default mht, gnn, jpda) on each scenario (default the validation preset group, S1-S6) and
seed (default 5 seeds, run 0 of each), the tracker steps through the run behind `FixedLag` with lag L
(default 3); the online and the lagged outputs are scored by `nnda.study.metrics.run_metrics` and printed
side by side, mean over seeds: the hit rate (%), the coverage (% of the target-scans a confirmed track is
matched to, the CLEAR-MOT position matching at the GOSPA cut-off) and GOSPA (m, mean over scans). The cost
is the time of the revision (`FixedLag.revise`, the flush included) against the tracker's own ``step``
(``time.perf_counter`` around each, one BLAS thread), as the ratio (step + revision) / step: the lagged
output's cost relative to the online one. Every tracker first runs one scenario untimed, so loading the
compiled kernels is not timed.

Usage: python benchmarks/bench_lag.py [--seeds N] [--lag L] [--trackers mht,gnn,jpda] [--scenarios validation]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

from nnda.data.generator import generate
from nnda.data.presets import resolve
from nnda.study.metrics import ScoredRun, run_metrics
from nnda.tracking.lag import FixedLag
from nnda.tracking.registry import make_tracker


def lagged_run(kind: str, dataset, lag: int):
    """The online and lagged outputs of ``kind`` on ``dataset``, and the seconds of its steps and of the
    revision."""
    fixed = FixedLag(make_tracker(kind, dataset.scenario.sensors, {}), lag)
    online, lagged, step_s, lag_s = [], [], 0.0, 0.0
    for scan in dataset.scans():
        t0 = time.perf_counter()
        out = fixed.tracker.step(scan)
        t1 = time.perf_counter()
        late = fixed.revise(out)
        t2 = time.perf_counter()
        step_s += t1 - t0
        lag_s += t2 - t1
        online.append(out)
        if late is not None:
            lagged.append(late)
    t0 = time.perf_counter()
    lagged += fixed.flush()
    lag_s += time.perf_counter() - t0
    return online, lagged, step_s, lag_s


def scores(dataset, outputs) -> tuple[float, float, float]:
    """Hit rate (%), coverage (% of target-scans matched by a confirmed track) and GOSPA (m)."""
    m = run_metrics(dataset, outputs)
    covered = ScoredRun(dataset, outputs).matches.scan.size / max(dataset.truth.scan.size, 1)
    hit = m.values["hit_rate"]
    return (np.nan if hit is None else float(hit)), 100.0 * covered, float(m.values["gospa"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--lag", type=int, default=3)
    ap.add_argument("--trackers", default="mht,gnn,jpda")
    ap.add_argument("--scenarios", default="validation", help="a preset, a preset group, or several, comma-separated")
    args = ap.parse_args()
    kinds = args.trackers.split(",")
    scenarios = [sc for name in args.scenarios.split(",") for sc in resolve(name)]
    print(f"fixed lag {args.lag} against the online output; {args.seeds} seed(s) (run 0) per scenario; "
          f"mean over seeds\n")
    header = (f"{'tracker':8} {'scenario':9} {'hit rate %':>17} {'coverage %':>17} {'GOSPA m':>17} "
              f"{'step ms/scan':>13} {'lag ms/scan':>12} {'cost ratio':>10}")
    with threadpool_limits(1):
        datasets = {sc.name: [generate(sc, seed, 0) for seed in range(args.seeds)] for sc in scenarios}
        for kind in kinds:
            lagged_run(kind, datasets[scenarios[0].name][0], args.lag)  # untimed: kernels loaded
        print(header)
        print("-" * len(header))
        for kind in kinds:
            total_step = total_lag = 0.0
            for sc in scenarios:
                rows, step_s, lag_s, n_scans = [], 0.0, 0.0, 0
                for ds in datasets[sc.name]:
                    online, lagged, s, g = lagged_run(kind, ds, args.lag)
                    rows.append((*scores(ds, online), *scores(ds, lagged)))
                    step_s, lag_s, n_scans = step_s + s, lag_s + g, n_scans + ds.n_scans
                mean = np.nanmean(np.array(rows), axis=0)
                cells = " ".join(f"{mean[i]:8.2f} >{mean[i + 3]:8.2f}" for i in range(3))
                print(f"{kind:8} {sc.name:9} {cells} {1e3 * step_s / n_scans:13.2f} {1e3 * lag_s / n_scans:12.3f} "
                      f"{(step_s + lag_s) / step_s:10.3f}")
                total_step, total_lag = total_step + step_s, total_lag + lag_s
            print(f"{kind:8} {'all':9} {'':53} {'':13} {'':12} {(total_step + total_lag) / total_step:10.3f}")
    print("\ncells: online > lagged. cost ratio: (tracker step + lag revision) / tracker step")


if __name__ == "__main__":
    main()
