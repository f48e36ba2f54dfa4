"""Speed of the models stage: pair extraction, LM and GD training, the numpy scorer.

Prints figures, and ratios against reference runs in the same process:
* training pairs of the 17 training presets: extraction time and pairs/s,
  for the three kinematic features and for the IMM-extended ones (which run the
  trackers' IMM along every target's contacts);
* the extended features of one scan as the neural tracker computes them
  (one call for every pair of K tracks), against one call per pair;
* Levenberg-Marquardt on the full pair set (3-5-1, Vargas Avila (2015)'s settings): the first
  fit of the process (it pays torch.func's one-off start-up) and the median
  of warm fits over 10 seeds; target < 2 s on 2 cores;
* gradient descent (1000 epochs) on the same problems, as the reference;
* the residual Jacobian per LM epoch: vmap(jacrev) (used) against jacfwd;
* the numpy scorer in pairs/s for batch sizes from one scan to a million
  pairs, against the torch forward pass on the same batch.

Run: .venv/bin/python benchmarks/bench_models.py [--quick]
(``--quick``: 2 seeds for the warm fits and scorer batches up to 1,000 pairs;
it checks that the benchmark runs, its figures mean little.)
"""

from __future__ import annotations

import argparse
import statistics
import time
import timeit

import numpy as np
import torch
from torch.func import jacfwd, jacrev, vmap

from nnda.data.generator import generate
from nnda.data.presets import resolve
from nnda.filters.imm import IMM
from nnda.models.experiment import fit
from nnda.models.innovation import IMM_INNOVATION, innovation_features
from nnda.models.network import as_tensor, forward
from nnda.models.pairs import pairs_from_datasets

SEEDS = range(10)
SCORER_BATCHES = (50, 1_000, 100_000, 1_000_000)


def best_of(fn, repeats: int) -> float:
    """Shortest wall time (s) of ``repeats`` calls of ``fn``."""
    return min(timeit.repeat(fn, number=1, repeat=repeats))


def extended_per_scan(sensor, n_tracks: int = 50, per_track: int = 4) -> None:
    """One scan's extended features for K tracks x a few candidates: one call, against one call per pair."""
    rng = np.random.default_rng(1)
    imm = IMM.for_sensor(sensor)
    r0, a0 = rng.uniform(8_000, 25_000, n_tracks), rng.uniform(0, 2 * np.pi, n_tracks)
    z1 = np.column_stack([r0, a0])
    z2 = z1 + np.column_stack([rng.normal(0, 200, n_tracks), rng.normal(0, 0.01, n_tracks)])
    pred = imm.predict(imm.initialise(z1, z2, 0.0, 2.0), 2.0)
    track = np.repeat(np.arange(n_tracks), per_track)
    contacts = z2[track] + np.column_stack([rng.normal(0, 300, track.size), rng.normal(0, 0.01, track.size)])
    kinematic, age = rng.normal(size=(track.size, 3)), np.full(track.size, 10.0)
    t_all = best_of(lambda: innovation_features(imm, pred, track, contacts, kinematic, age), 50)

    def per_pair():
        for i in range(track.size):
            innovation_features(imm, pred, track[i:i + 1], contacts[i:i + 1], kinematic[i:i + 1], age[i:i + 1])
    t_loop = best_of(per_pair, 3)
    print(f"extended features of one scan, {n_tracks} tracks x {per_track} candidates: "
          f"{t_all * 1e6:.0f} us in one call, {t_loop * 1e3:.1f} ms one call per pair ({t_loop / t_all:.0f}x)")


def main(seeds: range = SEEDS, batches: tuple[int, ...] = SCORER_BATCHES) -> None:
    torch.set_num_threads(1)  # as the trainers do (nnda.models.trainers)
    print(f"torch {torch.__version__}, 1 thread")
    datasets = [generate(s, 0) for s in resolve("train")]
    pairs = pairs_from_datasets(datasets)
    t_pairs = best_of(lambda: pairs_from_datasets(datasets), 5)
    print(f"\ntraining pairs: {len(pairs)} ({pairs.n_positive} own contact, {pairs.n_clutter} clutter) "
          f"from 17 datasets in {t_pairs * 1e3:.1f} ms = {len(pairs) / t_pairs:,.0f} pairs/s")
    t_ext = best_of(lambda: pairs_from_datasets(datasets, features=IMM_INNOVATION.name), 3)
    print(f"extended pairs ({IMM_INNOVATION.name}, IMM run along each history): {t_ext * 1e3:.1f} ms "
          f"= {len(pairs) / t_ext:,.0f} pairs/s ({t_ext / t_pairs:.1f}x the kinematic set's time)")
    extended_per_scan(datasets[0].scenario.sensor)

    t = time.perf_counter()
    first = fit(pairs, "lm", 5, seed=0)
    cold = time.perf_counter() - t
    print(f"\nLM, first fit of the process: {cold:.3f} s wall "
          f"(trainer clock {first.training.seconds:.3f} s, {first.training.epochs} epochs)")
    lm = [fit(pairs, "lm", 5, seed=s).training for s in seeds]
    gd = [fit(pairs, "gd", 5, seed=s).training for s in seeds]
    for name, runs in (("LM", lm), ("GD", gd)):
        secs = [r.seconds for r in runs]
        per_epoch = [r.seconds / max(r.epochs, 1) for r in runs]
        print(f"{name}, warm, {len(runs)} seeds: median {statistics.median(secs):.3f} s "
              f"(min {min(secs):.3f}, max {max(secs):.3f}), epochs median "
              f"{statistics.median(r.epochs for r in runs):.0f}, {statistics.median(per_epoch) * 1e3:.2f} ms/epoch")
    ratio = statistics.median(r.seconds for r in gd) / statistics.median(r.seconds for r in lm)
    print(f"GD / LM training time: {ratio:.1f}x  (LM target < 2 s: "
          f"{'met' if max(r.seconds for r in lm) < 2.0 else 'NOT met'} by every seed)")

    split = first.split.train
    x = as_tensor(first.scorer.normaliser.transform(pairs.features[split]))
    y = as_tensor(pairs.labels[split].astype(float))
    theta = as_tensor(first.scorer.weights.to_vector())

    def residuals(th):
        return forward(th, x, 5) - y

    def one(th, xi, yi):
        return forward(th, xi[None, :], 5)[0] - yi

    fwd = jacfwd(residuals)
    rev = vmap(jacrev(one), in_dims=(None, 0, 0))
    assert torch.allclose(fwd(theta), rev(theta, x, y), atol=1e-12)
    t_fwd, t_rev = best_of(lambda: fwd(theta), 20), best_of(lambda: rev(theta, x, y), 20)
    print(f"\nJacobian of {len(y)} residuals x {len(theta)} weights: vmap(jacrev) {t_rev * 1e3:.2f} ms (used), "
          f"jacfwd {t_fwd * 1e3:.2f} ms (jacfwd / vmap(jacrev) = {t_fwd / t_rev:.1f}x)")

    scorer = first.scorer
    rng = np.random.default_rng(0)
    print("\nscorer throughput (pairs/s): numpy scorer vs torch forward on normalised inputs")
    for n in batches:
        feats = pairs.features[rng.integers(0, len(pairs), n)]
        repeats = max(3, min(200, 2_000_000 // n))
        t_np = best_of(lambda: scorer(feats), repeats)
        xt = as_tensor(scorer.normaliser.transform(feats))
        with torch.no_grad():
            t_torch = best_of(lambda: forward(theta, xt, 5), repeats)
        print(f"  N = {n:>9,}: numpy {n / t_np:>13,.0f}  ({t_np * 1e6:9.1f} us/call)   "
              f"torch {n / t_torch:>13,.0f}   numpy/torch speed {t_torch / t_np:.2f}x")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 seeds, scorer batches up to 1,000 pairs")
    if parser.parse_args().quick:
        main(range(2), SCORER_BATCHES[:2])
    else:
        main()
