"""Study runner throughput: wall time and jobs per second, 2 local processes against 1 (issue 7).

Runs the specification's default study (every registered tracker of it:
IMM/TOMHT, the neural tracker with a GD and an LM model, GNN, JPDA) on
S1-S6 with RUNS Monte Carlo runs, once in this process (1 worker) and once on
two local worker processes, and prints wall time, jobs per second, the
speed-up, and each tracker's mean time per scan from the two runs.
Aggregation is included, the report is not. The models are trained first
(GD and LM on the 17 training presets). Usage:
python benchmarks/bench_study.py [RUNS]   (default 10; the issue's figure uses 100)
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from nnda.study.compare import compare
from nnda.study.config import default_study
from nnda.tracking.registry import TRACKERS


def train_models(directory: Path) -> None:
    """GD and LM models on the seed's features and an LM model on the extended ones, from the training
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


def main(runs: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        train_models(root / "models")
        study = default_study(root / "models/gd", root / "models/lm", root / "models/ext", runs=runs, seed=0)
        kept = {k: v for k, v in study.trackers.items() if v.kind in TRACKERS}
        study = study.model_copy(update={"trackers": kept})
        n_jobs = 6 * runs * len(kept)
        print(f"study: S1-S6 x {runs} runs x {len(kept)} trackers ({', '.join(kept)}) = {n_jobs} jobs")
        wall = {}
        for workers in (1, 2):
            out = root / f"out-{workers}"
            start = time.perf_counter()
            compare(study, out, workers=workers)
            wall[workers] = time.perf_counter() - start
            print(f"{workers} process(es): {wall[workers]:7.1f} s wall, {n_jobs / wall[workers]:6.1f} jobs/s")
            timing = json.loads((out / "timing.json").read_text())
            per = {t: sum(s["trackers"][t]["mean_time_per_scan_s"]["mean"] for s in timing["scenarios"]) / 6
                   for t in kept}
            print("    mean time per scan: " + ", ".join(f"{t} {v * 1e3:.2f} ms" for t, v in per.items()))
        same = all((root / "out-1" / f).read_bytes() == (root / "out-2" / f).read_bytes()
                   for f in ("results.parquet", "summary.json"))
        print(f"speed-up 2 processes / 1: {wall[1] / wall[2]:.2f}x; identical results: {same}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
