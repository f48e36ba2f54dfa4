"""Pedestrian speed: walker simulation, EK-PHD ms per scan on the stress scene, the Test 4 study.

Simulates WALKERS walkers for STEPS steps of 1 s on a 1 km x 1 km lawn with
a gravel band, a row of buildings, a gate along the west edge and a door
along the east edge (nobody reaches it in the run, so the crowd stays
WALKERS strong), with Frencl (2014)'s person set A and the leaf profile; prints
the truth simulation alone (`nnda.data.pedestrian.walkers.simulate`) and
the whole dataset with the ground radar (`walker_runs`), best of REPEAT
(target >= 1 M walker-steps/s at 1,000 walkers).

Then the thesis's filters on PHD_RUNS runs of ``walk-stress`` (100 scans,
10 initial, 6 spawned and spontaneous walkers; `nnda.study.pedestrian`'s
parameters): the EK-PHD with the modified NCSHT in ms per scan, the tracker's
``step`` alone on one BLAS thread (target <= 2 ms; the thesis's MATLAB run
took 53.24 s per 100 scans, 532 ms), beside the GM-PHD + CV and the UK-PHD
in the same process; and the whole Test 4 study (TEST4_RUNS runs of both
filters in the corridor, simulation, tracking and scoring) on JOBS
processes, wall-clock (target < 2 min for 600 runs on 2 cores).
Usage: python benchmarks/bench_pedestrian.py [--walkers 1000] [--steps 300] [--repeat 3] [--phd-runs 5]
[--test4-runs 600] [--jobs 2]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES, PERSON_SET_A
from nnda.data.pedestrian.terrain import TerrainMap, build_terrain
from nnda.data.pedestrian.walkers import WalkerScene, simulate, walker_runs
from nnda.study.compare import compare
from nnda.study.config import study_from_dict
from nnda.study.pedestrian import TEST_SPECS, track

#: the thesis's EK-PHD on its stress scene (Table 6.2): seconds per 100-scan run
THESIS_EKPHD_S = 53.24

SIDE_M = 1000.0
FIELD = TerrainMap.model_validate({
    "name": "field-1km", "width_m": SIDE_M, "height_m": SIDE_M,
    "regions": [
        {"kind": "difficult", "box": [100.0, 0.0, 160.0, SIDE_M]},
        *({"kind": "obstacle", "box": [300.0, y, 320.0, y + 60.0]} for y in np.arange(20.0, SIDE_M - 60.0, 100.0)),
        {"kind": "generator", "name": "west", "box": [0.0, 0.0, 4.0, SIDE_M], "accessible": ["east"]},
        {"kind": "sink", "name": "east", "box": [SIDE_M - 4.0, 0.0, SIDE_M, SIDE_M]},
    ],
})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walkers", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--phd-runs", type=int, default=5)
    ap.add_argument("--test4-runs", type=int, default=600)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    scene = WalkerScene(name="bench-walkers", map=FIELD, duration_s=float(a.steps), people=PERSON_SET_A,
                        initial=a.walkers, radar={"clutter_per_m2": 5.0 / SIDE_M**2})
    terrain = build_terrain(scene.map)
    best = best_ds = float("inf")
    for r in range(a.repeat):
        t0 = time.perf_counter()
        walks = simulate(scene, terrain, np.random.default_rng(r))
        best = min(best, time.perf_counter() - t0)
        t0 = time.perf_counter()
        ds = next(walker_runs(scene, [r]))
        best_ds = min(best_ds, time.perf_counter() - t0)
    steps = walks.scan.size
    print(f"{a.walkers} walkers x {a.steps} steps on a {SIDE_M:g} m square ({steps:,d} walker-steps)")
    print(f"  truth simulation         {best * 1e3:9.1f} ms  = {steps / best / 1e6:6.2f} M walker-steps/s "
          f"(target >= 1 M/s at 1,000 walkers)")
    print(f"  dataset with the radar   {best_ds * 1e3:9.1f} ms  = {steps / best_ds / 1e6:6.2f} M walker-steps/s "
          f"({ds.detections.scan.size:,d} detections)")
    phd(a.phd_runs)
    test4(a.test4_runs, a.jobs)


def phd(runs: int) -> None:
    """The Test 2 filters on ``runs`` runs of the stress scene: ms per scan of the tracker alone."""
    scene = PEDESTRIAN_SCENES["walk-stress"]
    data = list(walker_runs(scene, range(runs)))
    print(f"Test 2 filters on {runs} run(s) of {scene.name} ({scene.n_scans} scans, "
          f"{np.mean([len(d.scenario.targets) for d in data]):.0f} walkers and "
          f"{np.mean([d.detections.scan.size for d in data]) / scene.n_scans:.1f} contacts per scan on average)")
    ms = {}
    for f in TEST_SPECS["test2"].filters:
        ms[f.label] = 1e3 * sum(track(f, scene, d, "measurement").seconds for d in data) / (runs * scene.n_scans)
    reference = ms[TEST_SPECS["test2"].filters[0].label]
    for label, v in ms.items():
        print(f"  {label:<18} {v:7.2f} ms/scan  ({v / reference:4.2f} x {TEST_SPECS['test2'].filters[0].label})")
    ek = ms["EK-PHD + NCSHT"]
    print(f"  EK-PHD + NCSHT: {ek:.2f} ms/scan (target <= 2 ms); the thesis's {THESIS_EKPHD_S * 10:.0f} ms/scan is "
          f"{THESIS_EKPHD_S * 10 / ek:,.0f} x that")


def test4(runs: int, jobs: int) -> None:
    """The whole Test 4 study through the study engine (simulation, both filters, scoring, the aggregates) on
    ``jobs`` processes, wall-clock."""
    study = study_from_dict({"name": "bench-test4", "pedestrian": {"tests": ["test4"], "test4_runs": runs,
                                                                    "beyond": False}}, "bench")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        done = compare(study, Path(tmp) / "out", workers=jobs)
        seconds = time.perf_counter() - t0
    result = done.summary["pedestrian"]["tests"][0]
    steps = runs * PEDESTRIAN_SCENES["walk-test4"].n_scans * len(TEST_SPECS["test4"].filters)
    print(f"Test 4 study, {runs} runs x 2 filters on {jobs} process(es): {seconds:.1f} s "
          f"({1e3 * seconds / steps:.2f} ms per filter-scan; target < 120 s for 600 runs on 2 cores); "
          "points with 2 estimates: " + ", ".join(f"{label} {f['estimates_per_point']['2']['total']}"
                                                  for label, f in result["accuracy"]["filters"].items()))


if __name__ == "__main__":
    main()
