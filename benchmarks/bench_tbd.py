"""Track-before-detect speed (Bruno, Araújo & Pavlov): the frame likelihood, the filters per frame, the study.

1. Likelihood evaluations per second of `nnda.filters.frame_likelihood` (numba, parallel over particles),
   for nnda's 7 x 7 templates (the default aspects, their nonzero pixels read) and a full 7 x 7 block (all
   49 pixels), particles spread as in a filter (around the target, N(0, 3^2) pixels) and uniformly over the
   frame, against a plain numpy gather of the same offsets written here (the reference: numba's gain);
   and calls of one run's 5,000 particles (the filter's call size; one thread, best of 20 x repeat calls).
   Target: >= 20 M/s.
2. ms per frame on a 128 x 128 frame, one run: APF (paper form) at 5,000 particles, resample-move at 8,000,
   and the APF's standard form and SIS at 5,000 for scale. Target: APF <= 5 ms per frame.
3. The study's size: ``--study-runs`` runs x 20 frames at 6.5 and 8.1 dB, APF 5,000 and RS 8,000, frames
   simulated and filtered, seconds. Target: 100 runs in under 2 minutes.

Each timing is the best of ``--repeat`` rounds (a busy machine adds time, never removes it; the load average
is printed, as 2 shared cores make single rounds vary several-fold); numba's compilation happens before the
timed rounds.
Usage: python benchmarks/bench_tbd.py [--particles 1000000] [--repeat 3] [--frames 20] [--study-runs 100]
"""

from __future__ import annotations

import argparse
import os
import time

import numba
import numpy as np

from nnda.data import gmrf
from nnda.data.frames import FramesConfig, simulate, template_library
from nnda.filters.frame_likelihood import FrameLikelihood
from nnda.filters.tbd import TBDConfig, run_tbd, tbd_model


def numpy_llr(lik: FrameLikelihood, d_pad: np.ndarray, bh: float, bv: float, sc: float, x: np.ndarray,
              y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The reference: the same LLR of one run's particles (N,) by a numpy gather of every template offset."""
    hr, hc = lik.half
    A, h, w = lik.templates.shape
    row = np.rint(x).astype(np.int64) + hr
    col = np.rint(y).astype(np.int64) + hc
    k = z.astype(np.int64) - 1
    ok = (k >= 0) & (row >= 0) & (row < lik.rho0.shape[1]) & (col >= 0) & (col < lik.rho0.shape[2])
    row, col, k = row[ok], col[ok], k[ok]
    Mp = d_pad.shape[-1]
    offsets = (np.arange(h)[:, None] * Mp + np.arange(w)[None, :]).ravel()
    patches = d_pad.ravel()[(row * Mp + col)[:, None] + offsets]  # (n, h w)
    lam = np.einsum("np,np->n", patches, lik.templates.reshape(A, -1)[k])
    rho = lik.rho0[k, row, col] - 2 * (bh * lik.rhoh[k, row, col] + bv * lik.rhov[k, row, col])
    out = np.zeros(x.shape)
    out[ok] = (lam - 0.5 * rho) / sc**2
    return out


#: particles of one run's filter (the APF's), timed a call at a time in part 1
ONE_RUN = 5000


def best(f, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def part1(n: int, repeat: int) -> None:
    cfg = FramesConfig()
    rng = np.random.default_rng(0)
    Y = gmrf.sample(cfg.shape, cfg.beta_h, cfg.beta_v, cfg.sigma_c, rng, (1,))
    bh, bv, sc = np.full(1, cfg.beta_h), np.full(1, cfg.beta_v), np.full(1, cfg.sigma_c)
    print(f"\n1. likelihood evaluations per second, {n:,} particles on a {cfg.rows} x {cfg.cols} frame, "
          f"{numba.get_num_threads()} numba threads (best of {repeat})")
    print(f"{'templates':>22s}{'particles':>11s}{'pixels read':>13s}{'numba M/s':>11s}{'numpy M/s':>11s}"
          f"{'numba/numpy':>13s}{'5k-call M/s':>13s}")
    libraries = {"default 7x7 aspects": cfg.amplitude * template_library(),
                 "full 7x7 block": np.full((4, 7, 7), cfg.amplitude)}
    for label, templates in libraries.items():
        lik = FrameLikelihood(templates, cfg.shape)
        d_pad = lik.pad(gmrf.differential(Y, bh, bv))
        for spread in ("filter", "uniform"):
            x = np.empty((1, n, 5))
            if spread == "filter":
                x[..., 0], x[..., 2] = 64 + 3 * rng.standard_normal((2, 1, n))
            else:
                x[..., 0], x[..., 2] = rng.uniform(-3, 130, (2, 1, n))
            x[..., 4] = rng.integers(1, 5, (1, n))
            args = (d_pad, bh, bv, sc, x[..., 0], x[..., 2], x[..., 4])
            got = lik.llr(*args)
            ref = numpy_llr(lik, d_pad[0], bh[0], bv[0], sc[0], x[0, :, 0], x[0, :, 2], x[0, :, 4])
            assert np.allclose(got[0], ref, rtol=1e-9, atol=1e-9), "numba and numpy disagree"
            t_nb = best(lambda a=args, lk=lik: lk.llr(*a), repeat)
            t_np = best(lambda lk=lik, dp=d_pad, xx=x: numpy_llr(lk, dp[0], bh[0], bv[0], sc[0], xx[0, :, 0],
                                                                 xx[0, :, 2], xx[0, :, 4]), repeat)
            few = min(n, ONE_RUN)  # one run's particles a call: the kernel's one-thread path
            small = (d_pad, bh, bv, sc, x[:, :few, 0], x[:, :few, 2], x[:, :few, 4])
            t_small = best(lambda a=small, lk=lik: lk.llr(*a), 20 * repeat)
            pixels = float(lik.counts.mean())
            print(f"{label:>22s}{spread:>11s}{pixels:>13.1f}{n / t_nb / 1e6:>11.1f}{n / t_np / 1e6:>11.1f}"
                  f"{t_np / t_nb:>13.1f}{few / t_small / 1e6:>13.1f}")


def part2(frames: int, repeat: int) -> None:
    fs = simulate(FramesConfig(frames=frames, ptcr_db=8.1), 1, 0)
    print(f"\n2. ms per frame, one run of {frames} frames of 128 x 128 (best of {repeat})")
    print(f"{'filter':>14s}{'particles':>11s}{'ms/frame':>10s}{'evaluations/frame':>19s}")
    for name, n in (("apf", 5000), ("rs", 8000), ("apf-standard", 5000), ("sis", 5000)):
        model = tbd_model(fs, TBDConfig())
        run_tbd(model, name, n, 0)  # compile and warm
        out = []
        seconds = best(lambda m=model, f=name, k=n: out.append(run_tbd(m, f, k, 1)), repeat)
        print(f"{name:>14s}{n:>11d}{seconds / frames * 1e3:>10.2f}{out[-1].evaluations_per_frame:>19.0f}")


def part3(runs: int) -> None:
    t0 = time.perf_counter()
    for ptcr in (6.5, 8.1):
        fs = simulate(FramesConfig(ptcr_db=ptcr), runs, 0)
        for name, n in (("apf", 5000), ("rs", 8000)):
            run_tbd(tbd_model(fs, TBDConfig()), name, n, 1)
    print(f"\n3. the study's size: {runs} runs x 20 frames at 6.5 and 8.1 dB, APF 5,000 and RS 8,000: "
          f"{time.perf_counter() - t0:.1f} s")


def main() -> None:
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--study-runs", type=int, default=100)
    args = parser.parse_args()
    part1(args.particles, args.repeat)
    part2(args.frames, args.repeat)
    part3(args.study_runs)


if __name__ == "__main__":
    main()
