"""Tracker speed: ms per scan on S1-S6 and a scaling table.

Part 1: every registered tracker on S1-S6 (100 clutter points per scan),
mean and 95th-percentile wall time per scan, with the GNN and MHT as the
references run in the same process (ratio columns); every tracker first runs
one scenario untimed, so loading the compiled kernels is not timed.
Part 0: what numba bought: the IMM cycle of the contact trackers
(predict, gating prediction, update, estimate) compiled (`nnda.filters.imm_kernels`)
against the batched numpy formulation it replaced (`numpy_cycle`, kept here as
the reference), per call at tracking sizes, and the kernels' cold compile time
(an empty numba cache, in a fresh process) against loading them from the cache;
then the score rule's local clutter density (`nnda.tracking.clutter_density.local_density`,
a compiled summed-area table) against the numpy formulation it replaced
(`numpy_density`) and a compiled direct count per query over binned contacts
(`direct_density`), for N contacts over S1-S6's radar ring and Q = N query
points (the contacts: what a scan asks), with the covered part of each square. Part 2: the same trackers as clutter
grows 100 -> 1,000 -> 10,000 per scan (S6's six targets) and as targets grow
6 -> 50 -> 200 (100 clutter), over SCALING_SCANS scans each (``--scans``); a
tracker is dropped from the bigger settings once it passes 10 s per scan.

The neural tracker needs a model: pass ``--model PATH`` (a file written by
``nnda train``), once per model to time (e.g. the kinematic-feature and the
IMM-extended one: rows ``nn:kinematic-3``, ``nn:imm-innovation-9``), each
also with the neural life-cycle options (`LIFE`; rows ``nn:kinematic-3+life``
...); without it the neural tracker is skipped with a note.
Usage: python benchmarks/bench_trackers.py [--model PATH]... [--runs N] [--repeat R] [--scans N] [--no-scaling]
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.filters import kalman
from nnda.filters.imm import _TINY, IMM, IMMState
from nnda.filters.motion import process_noise
from nnda.models.scorer import load_model
from nnda.tracking.clutter_density import _covered, _covered_table, contact_cells, local_density, square_cells
from nnda.tracking.neural import life5
from nnda.tracking.registry import TRACKERS, make_tracker

SCALING_SCANS = 15
GIVE_UP_S = 10.0
#: the neural tracker's life-cycle options (`nnda.tracking.neural.life5`, the demo's nn-life): its "+life" rows
LIFE = life5()


def params_for(name: str, model: str | None) -> dict | None:
    if name == "nn":
        return None if model is None else {"model": model}
    return {}


def time_run(name: str, params: dict, dataset, give_up: float = math.inf, outputs: list | None = None) -> np.ndarray:
    """Seconds per scan of one tracker over one dataset (stops early past ``give_up`` s/scan);
    the tracker's outputs are appended to ``outputs`` when given."""
    return time_steps(make_tracker(name, dataset.scenario.sensor, params), dataset, give_up, outputs)


def time_steps(tracker, dataset, give_up: float = math.inf, outputs: list | None = None) -> np.ndarray:
    """`time_run` of a built ``tracker`` (anything with ``step(scan)``)."""
    times = []
    for scan in dataset.scans():
        t0 = time.perf_counter()
        out = tracker.step(scan)
        times.append(time.perf_counter() - t0)
        if outputs is not None:
            outputs.append(out)
        if times[-1] > give_up:
            break
    return np.array(times)


def many_targets(n: int, seed: int, scans: int) -> Scenario:
    """n targets spread over the coverage, 70-200 m/s, half of them turning, 100 clutter points."""
    rng = np.random.default_rng(seed)
    targets = []
    for i in range(n):
        r, b = rng.uniform(9_000, 24_000), rng.uniform(0, 2 * np.pi)
        speed = rng.uniform(70, 200)
        turn = {"normal_accel": float(rng.uniform(-5, 5))} if i % 2 else {}
        targets.append(Target(name=f"t{i}", x_m=r * np.sin(b), y_m=r * np.cos(b),
                              heading_deg=float(rng.uniform(0, 360)), speed_m_s=speed,
                              segments=[Segment(duration_s=2.0 * scans, **turn)]))
    return Scenario(name=f"targets{n}", duration_s=2.0 * scans, targets=targets,
                    clutter=Clutter(law="annulus", count=100))


def best_of(name: str, params: dict, dataset, repeat: int) -> np.ndarray:
    """Seconds per scan, each scan's fastest of ``repeat`` runs over the same dataset: on a machine
    shared with other work, closer to what the code costs than one run's times."""
    return np.min([time_run(name, params, dataset) for _ in range(repeat)], axis=0)


def entries(models: list[str]) -> list[tuple[str, str, dict]]:
    """(row label, tracker kind, params) of every tracker to time: gnn first (the reference), then the
    other registered kinds, the neural one twice per model (labelled with the model's feature set): with
    its defaults, and with the life options (`LIFE`, row "nn:<features>+life")."""
    rows = [("gnn", "gnn", {})]
    for kind in TRACKERS:
        if kind == "nn":
            for m in models:
                label = f"nn:{load_model(m).features.name}"
                rows += [(label, "nn", params_for("nn", m)), (f"{label}+life", "nn", {**params_for("nn", m), **LIFE})]
        elif kind != "gnn":
            rows.append((kind, kind, params_for(kind, None)))
    return rows


def numpy_cycle(imm: IMM, state: IMMState, dt: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """One IMM cycle of K tracks in the batched numpy formulation the compiled kernels replaced (eqs.
    4.46-4.55): mixing and model predictions, every model's measurement prediction, the combined (gating)
    measurement prediction, the update with z (K, 2) and the combined estimate. Returns what it computed."""
    K, r, n = state.x.shape
    tpm = np.array(imm.tpm)
    mu, x = state.mu, state.x
    mu_pred = mu @ tpm
    weights = (tpm.T * mu[:, None, :] + _TINY * np.eye(r)) / (mu_pred + _TINY)[:, :, None]
    x0 = weights @ x
    spread = x[:, None, :, :] - x0[:, :, None, :]
    P0 = (weights @ state.P.reshape(K, r, n * n)).reshape(K, r, n, n)
    P0 += (spread * weights[..., None]).swapaxes(-1, -2) @ spread
    F = np.zeros((K, r, n, n))
    xp = np.zeros((K, r, n))
    for j, m in enumerate(imm.models):
        xp[:, j, :m.dim] = m.transition(x0[:, j, :m.dim], dt, out=F[:, j, :m.dim, :m.dim])[0]
    Pp = kalman.propagate_covariance(F, P0, process_noise(dt, imm._noise_basis))
    mp = kalman.predict_measurement(xp, Pp, imm.measurement)
    state = IMMState(xp, Pp, mu_pred)
    gate = kalman.predict_measurement(*numpy_estimate(imm, state), imm.measurement)
    nu = kalman.innovation(z[:, None, :], mp, imm.measurement)
    xu, Pu = kalman.correct(xp, Pp, nu, mp)
    log_post = np.log(mu_pred + _TINY) + kalman.gaussian_log_likelihood(kalman.mahalanobis_2x2(nu, mp.S_inv),
                                                                        mp.log_det_S)
    mu_u = np.exp(log_post - log_post.max(axis=1, keepdims=True))
    mu_u /= mu_u.sum(axis=1, keepdims=True)
    return (*numpy_estimate(imm, IMMState(xu, Pu, mu_u)), gate.z, gate.S)


def numpy_estimate(imm: IMM, state: IMMState) -> tuple[np.ndarray, np.ndarray]:
    """The combined estimate (eqs. 4.54-4.55) in numpy, as `IMM.estimate` computed it before it was compiled."""
    d, K = imm.output_dim, len(state)
    x, P, w = state.x[..., :d], state.P[..., :d, :d], state.mu[:, None, :]
    xc = (w @ x)[:, 0]
    dx = x - xc[:, None, :]
    spread = dx[..., :, None] * dx[..., None, :] + P
    return xc, (w @ spread.reshape(K, imm.n_models, d * d)).reshape(K, d, d)


def compiled_cycle(imm: IMM, state: IMMState, dt: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """`numpy_cycle` through `IMM`'s compiled steps."""
    pred = imm.predict(state, dt, check=False)
    gate = pred.gating.measurement
    return (*imm.estimate(imm.update(pred, z, check=False)), gate.z, gate.S)


def cycle_inputs(K: int, seed: int = 0) -> tuple[IMMState, np.ndarray, np.ndarray]:
    """K tracks two scans after their two-point start, 6-24 km out, and a contact near each."""
    imm, rng = IMM(), np.random.default_rng(seed)
    r, b, v, h = rng.uniform(6e3, 2.4e4, K), rng.uniform(0, 2 * np.pi, K), rng.uniform(70, 200, K), \
        rng.uniform(0, 2 * np.pi, K)
    xy = lambda t: np.stack([r * np.sin(b) + v * t * np.sin(h), r * np.cos(b) + v * t * np.cos(h)], -1)  # noqa: E731
    polar = lambda p: np.stack([np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 0], p[:, 1]) % (2 * np.pi)], -1)  # noqa: E731
    state = imm.initialise(polar(xy(0.0)), polar(xy(2.0)), 0.0, 2.0)
    for t in (4.0, 6.0):
        state = imm.update(imm.predict(state, 2.0), polar(xy(t)))
    return state, np.full(K, 2.0), polar(xy(8.0)) + rng.normal(0, [30.0, 3e-3], (K, 2))


def part0(sizes: tuple[int, ...] = (5, 15, 40, 200), calls: int = 300) -> None:
    imm = IMM()
    print("\nIMM cycle (predict, gating prediction, update, estimate), microseconds per call, best of 5 x "
          f"{calls} calls")
    print(f"{'tracks':>8s}{'numpy':>10s}{'compiled':>10s}{'speed-up':>10s}   max |diff| / |value|")
    for K in sizes:
        args = cycle_inputs(K)
        a, b = numpy_cycle(imm, *args), compiled_cycle(imm, *args)
        diff = max(float(np.max(np.abs(u - v) / np.maximum(np.abs(u), 1e-300))) for u, v in zip(a, b))
        per = []
        for f in (numpy_cycle, compiled_cycle):
            best = math.inf
            for _ in range(5):
                t0 = time.perf_counter()
                for _ in range(calls):
                    f(imm, *args)
                best = min(best, (time.perf_counter() - t0) / calls)
            per.append(best * 1e6)
        print(f"{K:8d}{per[0]:10.1f}{per[1]:10.1f}{per[0] / per[1]:9.1f}x   {diff:.1e}")
    first = ("import time; t = time.perf_counter(); import nnda.filters.imm_kernels, nnda.tracking.lifecycle; "
             "from nnda.filters.imm import IMM; import numpy as np; imm = IMM(); "
             "s = imm.from_cv(np.array([[1e4, 1.0, 1e4, 1.0]]), np.eye(4)[None] * 100); "
             "p = imm.predict(s, 2.0); imm.mahalanobis(imm.combined_measurement(p), p.measurement.z[:, 0]); "
             "imm.estimate(imm.update(p, p.measurement.z[:, 0])); "
             "nnda.tracking.lifecycle.window_pairs(np.zeros((1, 2)), np.ones((1, 2)), 0.0, 2.0); "
             "print(time.perf_counter() - t)")
    with tempfile.TemporaryDirectory() as cache:
        cold, warm = (float(subprocess.run([sys.executable, "-c", first], capture_output=True, text=True, check=True,
                                           env={**os.environ, "NUMBA_CACHE_DIR": cache}).stdout) for _ in range(2))
    print(f"first IMM cycle in a fresh process: {cold:.1f} s with an empty numba cache (compiling), "
          f"{warm:.2f} s from the cache")


def numpy_density(contacts: np.ndarray, at: np.ndarray, radius: float, sensor: Sensor) -> np.ndarray:
    """`local_density` in the numpy formulation the compiled kernel replaced (the summed-area table by
    cumulative sums, the covered part's bilinear interpolation by fancy indexing). Returns (Q,) m^-2."""
    table, corner = _covered_table(sensor, radius)
    cell = radius / 4
    p = (at - corner) / cell - 0.5
    i = np.clip(np.floor(p).astype(np.int64), 0, len(table) - 2)
    w = np.clip(p - i, 0.0, 1.0)
    (a, b), (wa, wb) = i.T, w.T
    area = (2.0 * radius) ** 2 * ((1 - wa) * ((1 - wb) * table[a, b] + wb * table[a, b + 1])
                                  + wa * ((1 - wb) * table[a + 1, b] + wb * table[a + 1, b + 1]))
    lo = np.minimum(contacts.min(axis=0), at.min(axis=0)) - radius - cell
    hi = np.maximum(contacts.max(axis=0), at.max(axis=0)) + radius + cell
    shape = np.ceil((hi - lo) / cell).astype(np.int64) + 1
    idx = ((contacts - lo) // cell).astype(np.int64)
    counts = np.zeros(shape)
    np.add.at(counts, (idx[:, 0], idx[:, 1]), 1.0)
    sums = np.zeros(shape + 1)
    sums[1:, 1:] = counts.cumsum(axis=0).cumsum(axis=1)
    a, b = np.rint((at - radius - lo) / cell).astype(np.int64), np.rint((at + radius - lo) / cell).astype(np.int64)
    n = sums[b[:, 0], b[:, 1]] - sums[a[:, 0], b[:, 1]] - sums[b[:, 0], a[:, 1]] + sums[a[:, 0], a[:, 1]]
    return np.maximum(n, 1.0) / area


@numba.njit(cache=True, nogil=True)
def direct_density(contacts, at, radius, table, corner):
    """`local_density` (non-empty contacts and points) by a direct count per query: the contacts sorted
    into bins of one radius (4 cells), and each point's cells [a, b) tested against the contacts of the
    bins they touch. Returns (Q,) m^-2."""
    N, Q, cell, bins = contacts.shape[0], at.shape[0], radius / 4, 4
    lo0 = min(contacts[:, 0].min(), at[:, 0].min()) - radius - cell
    lo1 = min(contacts[:, 1].min(), at[:, 1].min()) - radius - cell
    ix, iy = contact_cells(contacts, lo0, lo1, cell)
    n0, n1 = ix.max() // bins + 1, iy.max() // bins + 1
    start = np.zeros(n0 * n1 + 1, np.int64)
    for i in range(N):
        start[(ix[i] // bins) * n1 + iy[i] // bins + 1] += 1
    for k in range(n0 * n1):
        start[k + 1] += start[k]
    fill, cx, cy = start[:-1].copy(), np.empty(N, np.int64), np.empty(N, np.int64)
    for i in range(N):
        k = (ix[i] // bins) * n1 + iy[i] // bins
        cx[fill[k]], cy[fill[k]] = ix[i], iy[i]
        fill[k] += 1
    out = np.empty(Q)
    for q in range(Q):
        x, y = at[q, 0], at[q, 1]
        a0, b0, a1, b1 = square_cells(x, y, radius, lo0, lo1, cell)
        n = 0
        for u in range(max(a0, 0) // bins, min((b0 - 1) // bins, n0 - 1) + 1):
            for v in range(max(a1, 0) // bins, min((b1 - 1) // bins, n1 - 1) + 1):
                for p in range(start[u * n1 + v], start[u * n1 + v + 1]):
                    n += a0 <= cx[p] < b0 and a1 <= cy[p] < b1
        out[q] = max(float(n), 1.0) / ((2.0 * radius) ** 2 * _covered(x, y, table, corner, cell))
    return out


def part0_density(sizes: tuple[int, ...] = (100, 1_000, 5_000), calls: int = 300, radius: float = 3_000.0) -> None:
    sensor = Sensor()  # S1-S6's radar: a 5-30 km ring
    table, corner = _covered_table(sensor, radius)
    print(f"\nlocal clutter density, Q = N points, microseconds per call, best of 5 x {calls} calls (radius "
          f"{radius:.0f} m)")
    print(f"{'contacts':>8s}{'numpy':>10s}{'direct':>10s}{'table':>10s}{'numpy/table':>13s}{'direct/table':>14s}"
          "   bits differ (numpy, direct)")
    rng = np.random.default_rng(0)
    for N in sizes:
        r = np.sqrt(rng.uniform(sensor.min_range_m**2, sensor.max_range_m**2, N))
        az = rng.uniform(-np.pi, np.pi, N)
        xy = np.column_stack([r * np.sin(az), r * np.cos(az)])
        ways = (lambda: numpy_density(xy, xy, radius, sensor), lambda: direct_density(xy, xy, radius, table, corner),
                lambda: local_density(xy, xy, radius, sensor))
        got = [f() for f in ways]
        differ = [int((g != got[2]).sum()) for g in got[:2]]
        per = []
        for f in ways:
            best = math.inf
            for _ in range(5):
                t0 = time.perf_counter()
                for _ in range(calls):
                    f()
                best = min(best, (time.perf_counter() - t0) / calls)
            per.append(best * 1e6)
        print(f"{N:8d}{per[0]:10.1f}{per[1]:10.1f}{per[2]:10.1f}{per[0] / per[2]:12.1f}x{per[1] / per[2]:13.1f}x"
              f"   {differ[0]}, {differ[1]} of {N}")


def part1(rows: list[tuple[str, str, dict]], runs: int, repeat: int = 1) -> None:
    best = f", each scan's best of {repeat} repeats" if repeat > 1 else ""
    print(f"\nms per scan on S1-S6 ({runs} run(s) each{best}; ratios = tracker / gnn and / mht, same process)")
    print(f"{'tracker':<24s}" + "".join(f"{s:>16s}" for s in ("S1", "S2", "S3", "S4", "S5", "S6")) + f"{'all':>16s}")
    means = {}
    warm_up = generate(PRESETS["S1"], seed=0)
    for label, kind, params in rows:
        time_run(kind, params, warm_up)
        per, every = [], []
        for sc in ("S1", "S2", "S3", "S4", "S5", "S6"):
            t = np.concatenate([best_of(kind, params, generate(PRESETS[sc], seed=run), repeat)
                                for run in range(runs)]) * 1e3
            per.append(f"{t.mean():7.2f} p95 {np.percentile(t, 95):5.2f}")
            every.append(t)
        allt = np.concatenate(every)
        means[label] = allt.mean()
        print(f"{label:<24s}" + "".join(f"{p:>16s}" for p in per) + f"{allt.mean():9.2f}")
    print(f"{'tracker':<24s}{'/ gnn':>8s}{'/ mht':>8s}   (all scans)")
    for label, mean in means.items():
        print(f"{label:<24s}" + "".join(f"{mean / means[r]:8.2f}" if r in means else f"{'-':>8s}"
                                        for r in ("gnn", "mht")))


def scaling_settings(scans: int = SCALING_SCANS) -> list[tuple[str, int, Scenario]]:
    """(axis, value, scenario) of the scaling runs: S6 with 100, 1,000 and 10,000 clutter points per
    scan, then 6, 50 and 200 targets with 100 clutter points; ``scans`` scans each."""
    settings = [("clutter", c, PRESETS["S6"].model_copy(update={
                    "duration_s": 2.0 * scans, "clutter": PRESETS["S6"].clutter.model_copy(update={"count": c})}))
                for c in (100, 1_000, 10_000)]
    return settings + [("targets", n, many_targets(n, seed=n, scans=scans)) for n in (6, 50, 200)]


def part2(rows: list[tuple[str, str, dict]], scans: int = SCALING_SCANS) -> None:
    settings = scaling_settings(scans)
    print(f"\nscaling: mean ms per scan over {scans} scans (x = stopped: over {GIVE_UP_S:.0f} s/scan before)")
    print(f"{'tracker':<24s}" + "".join(f"{k}={v:<9d}" for k, v, _ in settings))
    for label, kind, params in rows:
        row, stopped = [], {"clutter": False, "targets": False}
        for axis, _, scenario in settings:
            if stopped[axis]:
                row.append(f"{'x':>17s}")
                continue
            t = time_run(kind, params, generate(scenario, seed=1), GIVE_UP_S)
            stopped[axis] = t.max() > GIVE_UP_S
            row.append(f"{t.mean() * 1e3:>17.2f}")
        print(f"{label:<24s}" + "".join(row))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", action="append", default=[],
                        help="model file for the neural tracker (repeat to time several)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=1, help="time each S1-S6 run this many times and keep "
                        "each scan's fastest (for a busy machine)")
    parser.add_argument("--scans", type=int, default=SCALING_SCANS, help="scans per scaling setting")
    parser.add_argument("--no-scaling", action="store_true")
    parser.add_argument("--no-kernels", action="store_true", help="skip part 0 (the IMM cycle and the local "
                        "clutter density, numpy against compiled)")
    args = parser.parse_args()
    if not args.no_kernels:
        part0(calls=30 if args.scans < SCALING_SCANS else 300)
        part0_density(calls=30 if args.scans < SCALING_SCANS else 300)
    rows = entries(args.model)
    if not args.model:
        print("note: the neural tracker is skipped (give --model PATH, a file written by `nnda train`)")
    part1(rows, args.runs, args.repeat)
    if not args.no_scaling:
        part2(rows, args.scans)


if __name__ == "__main__":
    main()
