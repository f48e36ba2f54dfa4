"""Walker simulation speed (issue 15): walker-steps per second at 1,000 walkers (target >= 1 M/s).

Simulates WALKERS walkers for STEPS steps of 1 s on a 1 km x 1 km lawn with
a gravel band, a row of buildings, a gate along the west edge and a door
along the east edge (nobody reaches it in the run, so the crowd stays
WALKERS strong), with seed-000's person set A and the leaf profile; prints
the truth simulation alone (`nnda.data.pedestrian.walkers.simulate`) and
the whole dataset with the ground radar (`walker_runs`), best of REPEAT.
Usage: python benchmarks/bench_pedestrian.py [--walkers 1000] [--steps 300] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nnda.data.pedestrian.scenes import PERSON_SET_A
from nnda.data.pedestrian.terrain import TerrainMap, build_terrain
from nnda.data.pedestrian.walkers import WalkerScene, simulate, walker_runs

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


if __name__ == "__main__":
    main()
