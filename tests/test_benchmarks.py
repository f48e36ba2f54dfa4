"""`make bench` in small: every `benchmarks/bench_*.py` at its smallest size runs to the end (slow)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from nnda.models.feature_sets import feature_set
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, save_model

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
#: each benchmark's arguments for its smallest size; "{seed}" and "{ext}" are model files of the two
#: feature sets, for the benchmarks that time the neural tracker (`make bench` runs them without one)
SMALLEST = {
    "bench_clutter.py": ["--clutter", "200", "--scans", "3", "--model", "{ext}"],
    "bench_coverage_table.py": ["--range", "50", "--scans", "2"],
    "bench_features.py": ["--quick"],
    "bench_filters.py": ["2"],
    "bench_floor.py": ["--runs", "1", "--scans", "5", "--model", "{seed}"],
    "bench_fusion.py": ["--scans", "4", "--ships", "5", "--repeat", "1"],
    "bench_generate.py": ["2"],
    "bench_import.py": ["--rows", "2000", "--tracker", "gnn", "--scans", "3"],
    "bench_lag.py": ["--seeds", "1", "--scenarios", "S1", "--trackers", "gnn"],
    "bench_models.py": ["--quick"],
    "bench_particle.py": ["--sizes", "500", "--steps", "2", "--repeat", "1", "--resample-size", "1000",
                          "--memory-size", "500", "--study-runs", "1"],
    "bench_pedestrian.py": ["--walkers", "20", "--steps", "5", "--repeat", "1", "--phd-runs", "1", "--test4-runs", "2",
                            "--jobs", "1"],
    "bench_phd.py": ["--runs", "1", "--repeat", "1", "--scans", "2", "--peer-scans", "2"],
    "bench_scale.py": ["--targets", "20", "--scans", "3", "--model", "{seed}"],
    "bench_scaling.py": ["--scans", "2", "--give-up", "1", "--hard-stop", "5", "--out", "scaling.png",
                         "--model", "{seed}"],
    "bench_scoring.py": ["--targets", "20", "60"],
    "bench_study.py": ["1"],
    "bench_tbd.py": ["--particles", "2000", "--repeat", "1", "--frames", "2", "--study-runs", "1"],
    "bench_trackers.py": ["--runs", "1", "--scans", "2", "--model", "{seed}", "--model", "{ext}"],
}


def test_every_benchmark_has_a_smallest_size():
    assert sorted(p.name for p in BENCHMARKS.glob("bench_*.py")) == sorted(SMALLEST)


def write_model(path: Path, features: str) -> Path:
    """A scorer of seeded random weights on ``features``: what a benchmark needs of a model file."""
    fs = feature_set(features)
    weights = MLPWeights.from_vector(np.random.default_rng(0).normal(0.0, 0.5, n_weights(fs.size, 3)), fs.size, 3)
    return save_model(Scorer(weights, Normaliser(np.zeros(fs.size), np.full(fs.size, 10.0)), fs), path)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SMALLEST))
def test_benchmark_runs_at_its_smallest_size(name, tmp_path):
    models = {"seed": write_model(tmp_path / "seed.json", "kinematic-3"),
              "ext": write_model(tmp_path / "ext.json", "imm-innovation-9")}
    args = [a.format(**models) for a in SMALLEST[name]]
    run = subprocess.run([sys.executable, str(BENCHMARKS / name), *args], cwd=tmp_path, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, f"{name} {' '.join(args)} exited {run.returncode}:\n{run.stderr[-3000:]}"
