"""User data in and tracks out: `nnda import-detections` rows per second, `nnda track` overhead.

Prints, for a CSV of ROWS detections (one radar, 500 per 2-s sweep, seeded
uniform positions): the rate of `read_detections` (pyarrow's CSV reader,
checks, grouping into scans: target >= 1 M rows/s) and of the whole
import to disk (`import_detections`, including the dataset writer's checks,
Parquet files and digests). Then, for TRACKER on S6 (run 0, seed 0): the
tracker's own time (the sum of `Tracker.step`, as a study measures it), and
what `nnda.study.track.run_tracker` adds (building the tracker, the track
table, the scores: target < 5%), and what writing the outputs adds
(table file, PNG, HTML, scores.json).

Usage: python benchmarks/bench_import.py [--rows N] [--tracker NAME] [--scans N]
(``--scans`` cuts S6 to its first N scans, for a quick run).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from nnda.app.track_commands import write_track_outputs
from nnda.data.dataset import Dataset
from nnda.data.detections_import import import_detections, read_detections
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.study.track import run_tracker, tracker_params


def big_csv(path: Path, rows: int, per_sweep: int = 500) -> Path:
    rng = np.random.default_rng(0)
    time_s = (np.arange(rows) // per_sweep + 1) * 2.0
    pacsv.write_csv(pa.table({"time": time_s, "range": rng.uniform(5_000, 30_000, rows),
                              "azimuth": rng.uniform(0, 2 * np.pi, rows)}), path)
    return path


def bench_import(rows: int, work: Path) -> None:
    csv = big_csv(work / "big.csv", rows)
    sensors = [{"scan_period_s": 2.0}]
    best_read = best_all = float("inf")
    for i in range(3):
        t0 = time.perf_counter()
        read_detections(csv, sensors=sensors)
        t1 = time.perf_counter()
        import_detections(csv, work / "ds", overwrite=True, sensors=sensors)
        t2 = time.perf_counter()
        best_read, best_all = min(best_read, t1 - t0), min(best_all, t2 - t1)
    print(f"import-detections, {rows:,} rows ({csv.stat().st_size / 1e6:.1f} MB CSV), best of 3:")
    print(f"  read, check, group into scans  {best_read:7.3f} s  {rows / best_read:12,.0f} rows/s")
    print(f"  ... and write the dataset      {best_all:7.3f} s  {rows / best_all:12,.0f} rows/s")


def _cut(ds: Dataset, scans: int | None) -> Dataset:
    if scans is None or scans >= ds.n_scans:
        return ds
    sc = ds.scenario.model_copy(update={"duration_s": scans * ds.scenario.sensor.scan_period_s})
    return generate(sc, seed=0, run=0)


def bench_track(tracker: str, scans: int | None, model: str | None, work: Path) -> None:
    ds = _cut(generate(preset("S6"), seed=0, run=0), scans)
    params = tracker_params(None, model)
    run_tracker(ds, tracker, params)  # warm: imports, caches
    best = {}
    for _ in range(3):
        for score in (False, True):
            t0 = time.perf_counter()
            run = run_tracker(ds, tracker, params, score=score)
            wall = time.perf_counter() - t0
            own = float(run.step_seconds.sum())
            if (wall - own) / own < best.get(score, (float("inf"),))[0]:
                best[score] = ((wall - own) / own, own, wall)
    t1 = time.perf_counter()
    write_track_outputs(work / "track", ds, run, params, 1000.0, overwrite=True)
    writing = time.perf_counter() - t1
    print(f"nnda track {tracker} on S6 ({ds.n_scans} scans, {ds.detections.scan.size:,} detections), best of 3:")
    for score, what in ((False, "the track table (nnda.track)"), (True, "the table and the study's scores")):
        over, own, wall = best[score]
        print(f"  {what:34s} {wall:7.3f} s, the tracker's own {own:7.3f} s: +{100 * over:.1f}%")
    print(f"  writing tracks, PNG, HTML, scores  {writing:7.3f} s: +{100 * writing / best[True][1]:.1f}% (files)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--tracker", default="mht")
    parser.add_argument("--model", default=None, help="model file, for --tracker nn")
    parser.add_argument("--scans", type=int, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bench_import(args.rows, Path(tmp))
        bench_track(args.tracker, args.scans, args.model, Path(tmp))


if __name__ == "__main__":
    main()
