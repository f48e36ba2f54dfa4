"""The covered-area table of the local clutter density: a tracker's first scan, by coverage size.

Every tracker that reads the local clutter density of a sensor's scan
(`nnda.tracking.clutter_density.local_density` with the sensor: the
contact trackers' adaptive life cycle, JPDA, ...) needs the part of each
contact's square inside the coverage. That part was tabulated over the
whole coverage on the first scan (`_covered_table`: the cost grows with
the coverage's area); it is now filled lazily, the cells the scan's points
need (`_covered_cells`). And each scan's count was over the summed-area
table of the points' grid (1.1 million cells at 400 km); a wide scan is
now counted by strips (`_square_sums`). Per ``--range`` (km, a full-circle radar from 0.5
km, ``--contacts`` points spread uniformly over its coverage): the first
call in a fresh cache, whole table then density ("before") and lazily
filled ("after"), seconds (untraced) and peak MiB (tracemalloc, a second
call), with their ratios;
then the mean microseconds per call of later scans (new points each: "after"
still fills the cells they need for the first time), and whether the two
give the same densities (bits).

Usage: python benchmarks/bench_coverage_table.py [--range KM]... [--contacts N] [--scans N] [--radius M]
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from nnda.data.scenario import Sensor
from nnda.tracking import clutter_density as cd


def scan(sensor: Sensor, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points (n, 2) m uniform over the sensor's ring."""
    r = np.sqrt(rng.uniform(sensor.min_range_m**2, sensor.max_range_m**2, n))
    az = rng.uniform(-np.pi, np.pi, n)
    return np.column_stack([r * np.sin(az), r * np.cos(az)])


def whole_table(xy: np.ndarray, radius: float, sensor: Sensor) -> np.ndarray:
    """A scan as it was counted: the whole table (built on the first), then the density read from it, counted
    over the summed-area table of the points' grid."""
    table, corner = cd._covered_table(sensor, radius)
    return cd._density(xy, xy, radius, table, corner, 0)


def first_call(f, *args) -> tuple[float, float, np.ndarray]:
    """(seconds, peak MiB, result) of one call of ``f`` in fresh table caches: timed in one call, its memory
    traced (tracemalloc) in another."""
    cd._coverage_table.cache_clear()
    cd._coverage_cells.cache_clear()
    start = time.perf_counter()
    out = f(*args)
    seconds = time.perf_counter() - start
    cd._coverage_table.cache_clear()
    cd._coverage_cells.cache_clear()
    tracemalloc.start()
    f(*args)
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return seconds, peak, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--range", type=float, action="append", help="radar range in km (repeatable)")
    parser.add_argument("--contacts", type=int, default=100, help="points per scan")
    parser.add_argument("--scans", type=int, default=50, help="later scans timed per range")
    parser.add_argument("--radius", type=float, default=3_000.0, help="the square's half-side (m)")
    args = parser.parse_args()
    ranges = args.range or [50.0, 200.0, 400.0]
    radius = args.radius
    rng = np.random.default_rng(0)
    xy = np.zeros((1, 2))
    cd.local_density(xy, xy, radius, Sensor(max_range_m=10_000.0))  # compile outside the timings
    whole_table(xy, radius, Sensor(max_range_m=10_000.0))
    print(f"first scan of {args.contacts} contacts, local density with the covered part (radius {radius:.0f} m); "
          f"then {args.scans} later scans, us per call")
    print(f"{'range km':>8s}{'cells':>11s}{'before s':>10s}{'MiB':>9s}{'after s':>10s}{'MiB':>8s}"
          f"{'s ratio':>10s}{'MiB ratio':>11s}{'later us b/a':>15s}  same bits")
    for km in ranges:
        sensor = Sensor(min_range_m=500.0, max_range_m=1e3 * km)
        first = scan(sensor, args.contacts, rng)
        t0, m0, d0 = first_call(whole_table, first, radius, sensor)
        t1, m1, d1 = first_call(cd.local_density, first, first, radius, sensor)
        whole_table(first, radius, sensor)  # both caches warm, as a run's later scans find them
        later = [scan(sensor, args.contacts, rng) for _ in range(args.scans)]
        same = np.array_equal(d0, d1)
        per = []
        for f in (lambda p: whole_table(p, radius, sensor), lambda p: cd.local_density(p, p, radius, sensor)):
            start = time.perf_counter()
            got = [f(p) for p in later]
            per.append(1e6 * (time.perf_counter() - start) / len(later))
            same &= all(np.array_equal(g, whole_table(p, radius, sensor)) for g, p in zip(got, later, strict=True))
        n = len(cd._covered_cells(sensor, radius)[0])
        print(f"{km:8.0f}{n * n:11,d}{t0:10.3f}{m0:9.1f}{t1:10.4f}{m1:8.2f}{t0 / t1:10.0f}{m0 / m1:11.0f}"
              f"{per[0]:8.0f}/{per[1]:<6.0f}  {same}")


if __name__ == "__main__":
    main()
