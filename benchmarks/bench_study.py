"""The study engine's own cost on the demo's study: where a whole ``nnda run`` spends its wall time.

Trains the demo's networks (GD and LM on the thesis's features, LM on the
IMM-extended ones, from the 17 training presets), writes the demo's study
(`nnda.study.config.default_study`: MHT, four neural trackers, GNN, JPDA,
EK-PHD, CPHD on S1-S6) with RUNS Monte Carlo runs, and runs it as a user
does, ``nnda run --study ... --out ...`` in a new process, once on one
process and once on two local worker processes; then ``nnda report`` alone.
Prints per run: the command's wall time, its jobs phase (timing.json), the
rest (start-up, plan, aggregates, report), the trackers' own time (the sum
of every timed ``Tracker.step``, timing.parquet) and their share of the wall
time (also per worker: of the time the workers had), jobs per second and the
speed-up of two processes; and the report's time alone. Usage:
python benchmarks/bench_study.py [RUNS]   (default 10, the demo's size)
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pyarrow.parquet as pq

from nnda.study.config import default_study, study_to_toml


def train_models(directory: Path) -> None:
    """GD and LM models on the three kinematic features and an LM model on the extended ones, from the training
    presets (imports torch: kept out of the module, which the spawned worker processes import again)."""
    from nnda.data.generator import generate
    from nnda.data.presets import GROUPS, PRESETS
    from nnda.models.experiment import fit
    from nnda.models.pairs import pairs_from_datasets
    from nnda.models.scorer import save_model

    datasets = [generate(PRESETS[name]) for name in GROUPS["train"]]
    pairs = pairs_from_datasets(datasets)
    for method in ("gd", "lm"):
        save_model(fit(pairs, method, seed=0).scorer, directory / method / "model.json")
    ext = pairs_from_datasets(datasets, features="imm-innovation-9")
    save_model(fit(ext, "lm", seed=0, starts=3).scorer, directory / "ext" / "model.json")


def nnda(*args: str) -> float:
    """Run ``nnda ARGS`` in a new process; its wall time (s)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "nnda", *args], capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"nnda {' '.join(args)} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start


def main(runs: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        train_models(root / "models")
        study = default_study(root / "models/gd", root / "models/lm", root / "models/ext", runs=runs, seed=0)
        study_file = root / "study.toml"
        study_file.write_text(study_to_toml(study, relative_to=root))
        n_jobs = 6 * runs * len(study.trackers)
        print(f"the demo's study: S1-S6 x {runs} runs x {len(study.trackers)} trackers = {n_jobs} jobs; "
              f"`nnda run` as a whole process (start-up, plan, jobs, aggregates, report)")
        wall = {}
        for workers in (1, 2):
            out = root / f"out-{workers}"
            wall[workers] = nnda("run", "--study", str(study_file), "--out", str(out), "--jobs", str(workers))
            jobs_s = json.loads((out / "timing.json").read_text())["execution"]["seconds"]
            step_s = sum(sum(t) for t in pq.read_table(out / "timing.parquet").column("time_per_scan_s").to_pylist())
            print(f"{workers} process(es): {wall[workers]:6.1f} s wall = jobs {jobs_s:5.1f} s + the rest "
                  f"{wall[workers] - jobs_s:4.1f} s; {n_jobs / wall[workers]:5.1f} jobs/s; the trackers' steps "
                  f"{step_s:5.1f} s = {step_s / wall[workers]:.0%} of the wall time "
                  f"({step_s / (wall[workers] * workers):.0%} of the {workers} worker(s)' time)")
        report_s = nnda("report", str(root / "out-2"))
        same = all((root / "out-1" / f).read_bytes() == (root / "out-2" / f).read_bytes()
                   for f in ("results.parquet", "summary.json"))
        print(f"speed-up 2 processes / 1: {wall[1] / wall[2]:.2f}x; identical results: {same}; "
              f"`nnda report` alone: {report_s:.1f} s ({report_s / wall[2]:.0%} of the 2-process run)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
