"""Particle filter speed and memory on the re-entry model of Pavlov & Bruno (2003), ratios in one process.

1. The bootstrap step (multinomial resampling every step, one run of N particles) in us per 1,000
   particles, against a plain numpy bootstrap written here (same model, same draws in kind: exponential
   spacings for the sorted uniforms), and the optimal-importance step's time / the bootstrap's.
2. Resampling alone at ``--resample-size`` particles: ns per particle for each scheme.
3. Peak memory per particle (tracemalloc, untimed) of a whole filter run, float64 and float32.
4. Stone Soup's particle filter (optional peer, if importable: never imported by nnda itself) on the same
   model with drag off (its ConstantVelocity + LinearGaussian; it has no re-entry dynamics), against
   ours on that model.
5. The paper's study size: 100 runs x 4,000 particles x 55 steps, bootstrap and optimal, seconds.

Each timing is the best of ``--repeat`` rounds, the compared calls interleaved within a round. numba is not used:
it is not a dependency of nnda; the step is bound by numpy's vectorised arithmetic and random draws.
Usage: python benchmarks/bench_particle.py [--sizes 4000 100000 1000000] [--steps 10] [--repeat 3]
       [--resample-size 1000000] [--memory-size 100000] [--study-runs 100] [--no-peer]
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
from collections.abc import Callable

import numpy as np

from nnda.data.reentry import (
    GRAVITY,
    LAYER_ALTITUDE,
    ReentryConfig,
    initial_distribution,
    process_noise,
    simulate,
)
from nnda.filters.particle.resampling import RESAMPLERS
from nnda.filters.particle.smc import SMCConfig, run_smc
from nnda.filters.reentry import reentry_ssm


def best(calls: dict[str, Callable[[], object]], repeat: int) -> dict[str, float]:
    """The fastest of ``repeat`` rounds (s) of each call, the calls interleaved within a round so that a
    busy machine's load falls on all of them alike (load adds time, never removes it)."""
    times: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(repeat):
        for name, f in calls.items():
            t0 = time.perf_counter()
            f()
            times[name].append(time.perf_counter() - t0)
    return {name: min(t) for name, t in times.items()}


def numpy_bootstrap(data, n: int, seed: int) -> np.ndarray:
    """A plain numpy bootstrap filter of one run (the reference): (K, 4) weighted means."""
    cfg = data.config
    rng = np.random.default_rng(seed)
    m0, P0 = initial_distribution(cfg)
    LQt = np.ascontiguousarray(np.linalg.cholesky(process_noise(cfg)).T)  # contiguous: numpy's fast matmul
    dt, c = cfg.dt, -0.5 * GRAVITY / cfg.beta
    x = m0 + rng.standard_normal((n, 4)) @ np.linalg.cholesky(P0).T
    out = np.empty((data.steps, 4))
    for k in range(data.steps):
        y = x[:, 2]
        rho = np.where(y < LAYER_ALTITUDE, 1.227 * np.exp(-1.093e-4 * y), 1.754 * np.exp(-1.49e-4 * y))
        drag = c * rho * np.sqrt(x[:, 1] ** 2 + x[:, 3] ** 2)
        ax, ay = drag * x[:, 1], drag * x[:, 3] - GRAVITY
        new = np.empty_like(x)
        new[:, 0] = x[:, 0] + dt * x[:, 1] + 0.5 * dt * dt * ax
        new[:, 1] = x[:, 1] + dt * ax
        new[:, 2] = x[:, 2] + dt * x[:, 3] + 0.5 * dt * dt * ay
        new[:, 3] = x[:, 3] + dt * ay
        x = new + rng.standard_normal((n, 4)) @ LQt
        e = data.z[0, k] - x[:, ::2]
        Ri = np.linalg.inv(data.cov[0, k])
        logw = -0.5 * np.einsum("ni,ij,nj->n", e, Ri, e)
        w = np.exp(logw - logw.max())
        w /= w.sum()
        out[k] = w @ x
        E = np.cumsum(rng.standard_exponential(n + 1))
        C = np.cumsum(w)
        C[-1] = 1.0
        x = x[np.minimum(np.searchsorted(C, E[:-1] / E[-1], side="right"), n - 1)]
    return out


def part1(sizes: list[int], steps: int, repeat: int) -> None:
    print(f"\n1. one step, us per 1,000 particles (one run, {steps} steps, multinomial every step, best of {repeat})")
    print(f"{'N':>10s}{'numpy ref':>12s}{'bootstrap':>12s}{'boot/ref':>10s}{'optimal':>12s}{'opt/boot':>10s}"
          f"{'boot f32':>12s}")
    for n in sizes:
        data = simulate(ReentryConfig(steps=steps), 1, 0)
        model = reentry_ssm(data)
        per = 1e6 / steps / (n / 1000)
        t = best({"ref": lambda: numpy_bootstrap(data, n, 1),
                  "boot": lambda: run_smc(model, SMCConfig("bootstrap", n), 1),
                  "opt": lambda: run_smc(model, SMCConfig("optimal", n), 1),
                  "f32": lambda: run_smc(model, SMCConfig("bootstrap", n, dtype="float32"), 1)}, repeat)
        ref, boot, opt, f32 = (t[k] * per for k in ("ref", "boot", "opt", "f32"))
        print(f"{n:>10d}{ref:>12.1f}{boot:>12.1f}{boot / ref:>10.2f}{opt:>12.1f}{opt / boot:>10.2f}{f32:>12.1f}")


def part2(n: int, repeat: int) -> None:
    print(f"\n2. resampling {n:,} particles, ns per particle (best of {repeat})")
    rng = np.random.default_rng(0)
    W = rng.dirichlet(np.ones(n))[None]
    t = best({name: lambda f=f: f(W, n, rng) for name, f in RESAMPLERS.items()}, repeat)
    for name, seconds in t.items():
        print(f"{name:>12s}{seconds / n * 1e9:>10.1f}")


def part3(n: int) -> None:
    print(f"\n3. peak memory of a filter run with {n:,} particles (tracemalloc), bytes per particle")
    model = reentry_ssm(simulate(ReentryConfig(steps=3), 1, 0))
    for algorithm in ("bootstrap", "optimal"):
        for dtype in ("float64", "float32"):
            tracemalloc.start()
            tracemalloc.reset_peak()
            run_smc(model, SMCConfig(algorithm, n, dtype=dtype), 0)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            print(f"{algorithm:>12s} {dtype:>8s}{peak / n:>10.0f}")


def stonesoup_step(data, n: int, steps: int) -> float | None:
    """Seconds per step of Stone Soup's particle filter (ConstantVelocity q = 1, LinearGaussian with R_k,
    systematic resampling every step) on one run; None if Stone Soup is not importable."""
    try:
        from datetime import datetime, timedelta

        from stonesoup.models.measurement.linear import LinearGaussian
        from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
        from stonesoup.predictor.particle import ParticlePredictor
        from stonesoup.resampler.particle import SystematicResampler
        from stonesoup.types.array import StateVectors
        from stonesoup.types.detection import Detection
        from stonesoup.types.hypothesis import SingleHypothesis
        from stonesoup.types.state import ParticleState
        from stonesoup.updater.particle import ParticleUpdater
    except ImportError:
        return None
    cfg = data.config
    m0, P0 = initial_distribution(cfg)
    rng = np.random.default_rng(0)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(cfg.sigma_w**2)] * 2)
    predictor = ParticlePredictor(transition)
    start = datetime(2026, 1, 1)
    state = ParticleState(state_vector=StateVectors((m0 + rng.standard_normal((n, 4)) @ np.linalg.cholesky(P0).T).T),
                          weight=np.full(n, 1.0 / n), timestamp=start)
    t0 = time.perf_counter()
    for k in range(steps):
        when = start + timedelta(seconds=cfg.dt * (k + 1))
        mm = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=data.cov[0, k])
        updater = ParticleUpdater(mm, resampler=SystematicResampler())
        pred = predictor.predict(state, timestamp=when)
        state = updater.update(SingleHypothesis(pred, Detection(data.z[0, k][:, None], when, mm)))
    return (time.perf_counter() - t0) / steps


def part4(n: int, steps: int, repeat: int) -> None:
    data = simulate(ReentryConfig(drag=False, steps=steps), 1, 0)
    model = reentry_ssm(data)
    peer: list[float] = []
    t = best({"peer": lambda: peer.append(stonesoup_step(data, n, steps)),
              "ours": lambda: run_smc(model, SMCConfig("bootstrap", n, resampling="systematic"), 1)}, repeat)
    if peer[0] is None:
        print("\n4. Stone Soup is not importable: its particle filter is skipped")
        return
    per = 1e6 / steps / (n / 1000)
    print(f"\n4. drag off, {n:,} particles, systematic resampling every step: us per 1,000 particles per step\n"
          f"   Stone Soup {min(peer) * 1e6 / (n / 1000):.1f}, nnda bootstrap {t['ours'] * per:.1f}: "
          f"nnda {min(peer) * steps / t['ours']:.1f}x faster")


def part5(runs: int) -> None:
    data = simulate(ReentryConfig(), runs, 0)
    model = reentry_ssm(data)
    times = best({a: lambda a=a: run_smc(model, SMCConfig(a, 4000), 1) for a in ("bootstrap", "optimal")}, 1)
    print(f"\n5. the paper's study: {runs} runs x 4,000 particles x {data.steps} steps: " +
          ", ".join(f"{a} {t:.1f} s" for a, t in times.items()) + f", both {sum(times.values()):.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[4000, 100_000, 1_000_000])
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--resample-size", type=int, default=1_000_000)
    parser.add_argument("--memory-size", type=int, default=100_000)
    parser.add_argument("--study-runs", type=int, default=100)
    parser.add_argument("--no-peer", action="store_true", help="leave Stone Soup out")
    args = parser.parse_args()
    part1(args.sizes, args.steps, args.repeat)
    part2(args.resample_size, args.repeat)
    part3(args.memory_size)
    if not args.no_peer:
        part4(min(args.sizes[0], 4000), args.steps, args.repeat)
    part5(args.study_runs)


if __name__ == "__main__":
    main()
