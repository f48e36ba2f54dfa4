"""The floor: what a contact tracker's scan costs when all of it is one compiled call, and each tracker's ratio to it.

`floor_scan` does a whole scan of an IMM tracker in one numba call, with nnda's own compiled kernels
(`nnda.filters.imm_kernels`: the IMM mixing and prediction and the polar measurement prediction in `predict`, the
gate with its azimuth wrap in `gated_pairs`, the IMM update in `update`, two-point starts in `start`, the combined
estimate in `estimate`; `nnda.tracking.assignment.greedy_kernel` for the assignment) and the glue between them:
greedy least-cost assignment (a pair costs d^2 + log|S|, cheapest first), an M/N life cycle (confirmed at M
contacts in the last N scans, a preliminary track deleted once N scans passed without that, a confirmed one after
more than ``max_misses`` misses in a row), two-point initiation (each contact no track took opens a track with the
nearest of the previous scan's free contacts inside the initiation window, the others wait as next initiators) and
every track's estimate written out. It is what the trackers' scans cannot go below without dropping work; they do
more (gnn: confirmed tracks first, the poorly-linearised fallback update, the clutter-adaptive score rule, the
sanity rules, checks on input), so the ratio is an upper bound on what their Python layer costs.

Printed: ms per scan on S1-S6 (``--runs`` seeded runs each, 100 clutter points a scan) of the floor and of every
contact tracker (gnn, jpda, mht; with ``--model PATH`` nn and nn-life, the neural tracker with the demo's life-cycle
options, `nnda.tracking.neural.life5`), all in this process after an untimed warm-up run of each on every scenario
(a seed the timing does not use: code a scene reaches first, such as the fallback update of a track coasting near
the radar, loads from numba's cache before the clock runs), the ratio tracker / floor, and the floor's mean GOSPA
beside gnn's (m; a check that its tracks are sane).
Each run is timed in ``--repeats`` rounds over all the trackers (default 3) and each tracker's fastest round
counts: the machine's other work slows one round by 10-30 %, and a tracker timed alone in such a spell would
show a ratio that much off (the same code measured 5.5x and 6.2x the floor in two single-round runs).
Usage: python benchmarks/bench_floor.py [--runs N] [--scans N] [--model PATH] [--repeats R]
"""

from __future__ import annotations

import argparse
import math

import numba
import numpy as np

from bench_trackers import LIFE, params_for, time_run, time_steps
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.filters import imm_kernels
from nnda.filters.imm import IMM
from nnda.study.metrics import run_metrics
from nnda.tracking.assignment import greedy_kernel
from nnda.tracking.lifecycle import LifecycleConfig, sensor_noise_m
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY, TrackerOutput
from nnda.tracking.registry import make_tracker

SCENARIOS = ("S1", "S2", "S3", "S4", "S5", "S6")
CONTACT_TRACKERS = ("gnn", "jpda", "mht", "nn", "nn-life")


@numba.njit(cache=True, nogil=True)
def _bits(h):
    n = 0
    while h:
        n += h & 1
        h >>= 1
    return n


@numba.njit(cache=True, nogil=True)
def floor_scan(x, P, mu, t_last, ids, status, hits, age, misses, init_xy, init_time, next_id, Z, now,
               tpm, kinds, dims, omega_max, basis, augment, polar, origin, R, d, gate, m, n, max_misses,
               d_min, d_max, x_rest, P_rest, mu0):
    """One scan of the floor tracker (module docstring) over K live tracks (x (K, r, n), P, mu, last update time,
    id, status, M/N hit bits, age in scans, consecutive misses) and the previous scan's free contacts init_xy
    (I, 2) at init_time; Z (N, 2) the scan's contacts at time ``now``. Returns the next state and the scan's
    report (ids, status, x (M, d), P (M, d, d), contact)."""
    K, N = x.shape[0], Z.shape[0]
    xy = np.empty((N, 2))
    cov = np.empty((N, 2, 2))
    for j in range(N):  # contact positions and their covariance (J R J^T), for the starts
        if polar:
            s, c, rng = math.sin(Z[j, 1]), math.cos(Z[j, 1]), Z[j, 0]
            xy[j, 0], xy[j, 1] = origin[0] + rng * s, origin[1] + rng * c
            J = ((s, rng * c), (c, -rng * s))
            for u in range(2):
                for v in range(2):
                    cov[j, u, v] = (J[u][0] * (R[0, 0] * J[v][0] + R[0, 1] * J[v][1])
                                    + J[u][1] * (R[1, 0] * J[v][0] + R[1, 1] * J[v][1]))
        else:
            xy[j] = Z[j]
            cov[j] = R
    pick = np.full(K, NO_CONTACT, np.int64)
    taken = np.zeros(N, np.bool_)
    xu, Pu, mu_u = x, P, mu
    if K:
        (xp, Pp, mu_p, zm, Sm, Sm_inv, log_det, Hm, PHt, bad,
         xc, Pc, zc, Sc, Sc_inv, log_det_c, Hc, PHtc, bad_c) = imm_kernels.predict(
            x, P, mu, now - t_last, tpm, kinds, dims, omega_max, basis, augment, polar, origin, R, d)
        rows, cols, d2 = imm_kernels.gated_pairs(zc, Sc_inv, np.arange(K), Z, np.array([gate]), polar)
        if rows.size:
            kept, chosen = greedy_kernel(rows, cols, -(d2 + log_det_c[rows]))
            pick[kept] = chosen
            taken[chosen] = True
        zk = np.zeros((K, 2))
        for k in range(K):
            if pick[k] >= 0:
                zk[k] = Z[pick[k]]
        xu, Pu, mu_u = imm_kernels.update(xp, Pp, mu_p, zk, pick >= 0, zm, Sm_inv, log_det, PHt, polar)
    # M/N life cycle
    window = (1 << n) - 1
    new_status = status.copy()
    for k in range(K):
        hit = pick[k] >= 0
        hits[k] = ((hits[k] << 1) | (1 if hit else 0)) & window
        age[k] += 1
        misses[k] = 0 if hit else misses[k] + 1
        if status[k] == PRELIMINARY:
            if _bits(hits[k]) >= m:
                new_status[k] = CONFIRMED
            elif age[k] >= n:
                new_status[k] = DELETED
        elif misses[k] > max_misses:
            new_status[k] = DELETED
    # two-point initiation from the free contacts
    free = np.flatnonzero(~taken)
    opened_from = np.full(free.size, -1, np.int64)
    used_init = np.zeros(init_xy.shape[0], np.bool_)
    lo, hi = d_min * d_min, d_max * d_max
    for f in range(free.size):
        j = free[f]
        best, best_d = -1, np.inf
        for i in range(init_xy.shape[0]):
            dx = xy[j, 0] - init_xy[i, 0]
            if used_init[i] or abs(dx) > d_max:
                continue
            dy = xy[j, 1] - init_xy[i, 1]
            dist = dx * dx + dy * dy
            if lo <= dist <= hi and dist < best_d:
                best, best_d = i, dist
        if best >= 0:
            used_init[best] = True
            opened_from[f] = best
    born = np.flatnonzero(opened_from >= 0)
    B = born.size
    bj = free[born]
    xb, Pb, mub = imm_kernels.start(init_xy[opened_from[born]], xy[bj], cov[bj], np.array([now - init_time]),
                                    x_rest, P_rest, mu0)
    # the report: every old track (deleted ones once more), then the new ones
    x_all = np.concatenate((xu, xb))
    P_all = np.concatenate((Pu, Pb))
    mu_all = np.concatenate((mu_u, mub))
    est_x, est_P = imm_kernels.estimate(x_all, P_all, mu_all, d)
    out_ids = np.concatenate((ids, np.arange(next_id, next_id + B)))
    out_status = np.concatenate((new_status, np.full(B, PRELIMINARY, np.int8)))
    out_contact = np.concatenate((pick, bj))
    live = np.flatnonzero(out_status != DELETED)
    state = (x_all[live], P_all[live], mu_all[live], np.full(live.size, now), out_ids[live], out_status[live],
             np.concatenate((hits, np.ones(B, np.int64)))[live], np.concatenate((age, np.ones(B, np.int64)))[live],
             np.concatenate((misses, np.zeros(B, np.int64)))[live], xy[free[opened_from < 0]], now,
             next_id + B)
    return state, (out_ids, out_status, est_x, est_P, out_contact)


class FloorTracker:
    """`floor_scan` with its state, one compiled call a scan; the IMM and life-cycle settings are gnn's."""

    def __init__(self, sensor) -> None:
        gnn = make_tracker("gnn", sensor, {})
        imm: IMM = gnn.filter
        life = LifecycleConfig()
        self.params = (imm._tpm, imm._kinds, imm._dims, imm._omega_max, imm._noise_basis, imm._augment,
                       imm.polar, imm._origin, imm.measurement.R, imm.output_dim, gnn.config.gate, life.m, life.n,
                       life.max_misses, *life.window(sensor.scan_period_s, sensor_noise_m(sensor)),
                       *imm._cv_extension, imm._mu0_array)
        r, dim = imm.n_models, imm.dim
        self.state = (np.empty((0, r, dim)), np.empty((0, r, dim, dim)), np.empty((0, r)), np.empty(0),
                      np.empty(0, np.int64), np.empty(0, np.int8), np.empty(0, np.int64), np.empty(0, np.int64),
                      np.empty(0, np.int64), np.empty((0, 2)), -np.inf, 0)

    def step(self, scan) -> TrackerOutput:
        self.state, report = floor_scan(*self.state, scan.measurements, scan.time, *self.params)
        return TrackerOutput(scan.index, scan.time, *report)


def floor_run(dataset, outputs: list | None = None) -> np.ndarray:
    """Seconds per scan of the floor over ``dataset`` (its output built, as every tracker's); its outputs
    appended to ``outputs``."""
    return time_steps(FloorTracker(dataset.scenario.sensor), dataset, outputs=outputs)


def tracker_run(name: str, model: str | None, dataset, outputs: list | None = None) -> np.ndarray:
    """`time_run` of the contact tracker of row ``name`` ("nn-life": nn with `bench_trackers.LIFE`)."""
    if name == "nn-life":
        return time_run("nn", {**params_for("nn", model), **LIFE}, dataset, outputs=outputs)
    return time_run(name, params_for(name, model), dataset, outputs=outputs)


def shortened(scenario, scans: int | None):
    """``scenario`` cut to its first ``scans`` scans (None: whole)."""
    if scans is None:
        return scenario
    return scenario.model_copy(update={"duration_s": min(scenario.duration_s, scans * scenario.sensor.scan_period_s)})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="seeded runs of each scenario")
    parser.add_argument("--scans", type=int, help="only the first N scans of each scenario (default: all)")
    parser.add_argument("--repeats", type=int, default=3, help="rounds over the trackers on each run; each "
                        "tracker's fastest round counts")
    parser.add_argument("--model", help="model file for the neural tracker (without: nn is skipped)")
    args = parser.parse_args()
    names = ["floor", *(n for n in CONTACT_TRACKERS if not n.startswith("nn") or args.model)]
    if not args.model:
        print("note: the neural tracker is skipped (give --model PATH, a file written by `nnda train`)")
    for sc in SCENARIOS:
        warm = generate(shortened(PRESETS[sc], args.scans), seed=args.runs)
        floor_run(warm)
        for name in names[1:]:
            tracker_run(name, args.model, warm)
    ms = {(name, sc): [] for name in names for sc in SCENARIOS}
    gospa = {(name, sc): [] for name in ("floor", "gnn") for sc in SCENARIOS}
    for sc in SCENARIOS:
        for run in range(args.runs):
            dataset = generate(shortened(PRESETS[sc], args.scans), seed=run)
            fastest = {}
            for _ in range(args.repeats):  # rounds over the trackers: a slow spell of the machine falls on all
                for name in names:
                    outputs = []
                    t = floor_run(dataset, outputs) if name == "floor" else tracker_run(name, args.model, dataset,
                                                                                        outputs)
                    if name not in fastest or t.sum() < fastest[name].sum():
                        fastest[name] = t
                    if name in ("floor", "gnn") and len(gospa[name, sc]) <= run:
                        gospa[name, sc].append(float(run_metrics(dataset, outputs).gospa.mean()))
            for name in names:
                ms[name, sc].append(fastest[name] * 1e3)
    mean = {key: float(np.concatenate(v).mean()) for key, v in ms.items()}
    every = {name: float(np.concatenate([np.concatenate(ms[name, sc]) for sc in SCENARIOS]).mean()) for name in names}
    print(f"\nms per scan on S1-S6 ({args.runs} run(s) each, same process), and the ratio to the floor")
    print(f"{'tracker':<10s}" + "".join(f"{sc:>9s}" for sc in SCENARIOS) + f"{'all':>9s}{'/ floor':>9s}")
    for name in names:
        print(f"{name:<10s}" + "".join(f"{mean[name, sc]:9.3f}" for sc in SCENARIOS)
              + f"{every[name]:9.3f}{every[name] / every['floor']:9.1f}")
    print(f"\nmean GOSPA (m) over the scans, {args.runs} run(s) each: the floor's tracks beside gnn's")
    print(f"{'tracker':<10s}" + "".join(f"{sc:>9s}" for sc in SCENARIOS))
    for name in ("floor", "gnn"):
        print(f"{name:<10s}" + "".join(f"{np.mean(gospa[name, sc]):9.1f}" for sc in SCENARIOS))


if __name__ == "__main__":
    main()
