"""The pedestrian study's scoring (Frencl 2014, Tests 1-4): estimates given to true points, RMS, set measures.

Scoring (our reading where the thesis is vague): an
estimate belongs to the true point of its scan nearest to it when closer
than ``cutoff_m`` (c, also the OSPA/GOSPA cut-off, p = 2); a true point with
no estimate within c is *missed* and enters no RMS. Per time k over runs:

* RMS_x(k) = sqrt(sum (x - x^)^2 / N_k) with the closest estimate of each of
  the N_k true points that have one (the thesis's min-distance method);
  ``punished``: every estimate of a point in the numerator, N_k kept;
* the tables' mean RMS_x, RMS_y: the mean over k of RMS_x(k), RMS_y(k);
* excess estimates (Test 4): true points with exactly 2, exactly 3 and more
  than 3 estimates (the thesis's rows read as the number of estimates);
* per run: OSPA and GOSPA (means over scans), the mean |extracted count -
  true count| and the mean bias of the extracted count and of the
  intensity's total weight, the missed share, the time per scan.

Intervals: the mean-RMS figures are ratios over runs, so their intervals are
percentile bootstraps over runs (``bootstrap`` resamples, paired: the same
resampled runs for every filter, which gives the differences' intervals);
per-run measures take Student-t intervals (`nnda.study.stats.mean_ci`).
A verdict reads an interval: a difference whose interval excludes 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnda.data.pedestrian.profiles import HeadingProfile
from nnda.study.gospa import gospa, ospa
from nnda.study.stats import bootstrap_indices, mean_ci, percentile_interval, root_mean_square


@dataclass(frozen=True)
class Trace:
    """One filter on one run: true points ``truth_scan`` (M,), ``truth_xy`` (M, 2); estimates ``est_scan``
    (E,), ``est_xy`` (E, 2); per scan (K,) the extracted count and the intensity's total weight; seconds."""

    truth_scan: np.ndarray
    truth_xy: np.ndarray
    est_scan: np.ndarray
    est_xy: np.ndarray
    extracted: np.ndarray
    weight: np.ndarray
    seconds: float


@dataclass(frozen=True)
class Owned:
    """Estimates given to true points (module docstring) of one run with K scans, by scan (K,): per axis
    the closest estimate's squared error summed over the points that have one (``close_x``, ``close_y``),
    every estimate's (``all_x``, ``all_y``), points with an estimate (``found``), points (``points``);
    and per true point (M,) its number of estimates (``count``)."""

    close_x: np.ndarray
    close_y: np.ndarray
    all_x: np.ndarray
    all_y: np.ndarray
    found: np.ndarray
    points: np.ndarray
    count: np.ndarray


def owned(trace: Trace, n_scans: int, cutoff: float) -> Owned:
    """`Owned` of one trace: each estimate goes to the nearest true point of its scan within ``cutoff`` m
    (one (estimate, point) distance matrix per scan: a handful of each)."""
    M = len(trace.truth_scan)
    owner = np.full(len(trace.est_scan), -1)
    dist = np.full(len(trace.est_scan), np.inf)
    t_bounds = np.searchsorted(trace.truth_scan, np.arange(1, n_scans + 2))
    e_bounds = np.searchsorted(trace.est_scan, np.arange(1, n_scans + 2))
    for k in range(n_scans):
        t0, t1, e0, e1 = t_bounds[k], t_bounds[k + 1], e_bounds[k], e_bounds[k + 1]
        if t1 > t0 and e1 > e0:
            d = np.linalg.norm(trace.est_xy[e0:e1, None, :] - trace.truth_xy[None, t0:t1, :], axis=2)
            owner[e0:e1], dist[e0:e1] = t0 + d.argmin(axis=1), d.min(axis=1)
    mine = dist < cutoff
    e, o = np.flatnonzero(mine), owner[mine]
    err = trace.est_xy[e] - trace.truth_xy[o]
    count = np.bincount(o, minlength=M)
    # the closest estimate of each point: the first of its estimates sorted by distance
    order = np.lexsort((dist[e], o))
    first = order[np.r_[True, o[order][1:] != o[order][:-1]]] if len(order) else order
    scan_of = trace.truth_scan - 1

    def per_scan(values: np.ndarray, points: np.ndarray) -> np.ndarray:
        return np.bincount(scan_of[points], values, minlength=n_scans)

    return Owned(per_scan(err[first, 0] ** 2, o[first]), per_scan(err[first, 1] ** 2, o[first]),
                 per_scan(err[:, 0] ** 2, o), per_scan(err[:, 1] ** 2, o),
                 per_scan(np.ones(len(first)), o[first]), per_scan(np.ones(M), np.arange(M)), count)


def _rms(sq: np.ndarray, found: np.ndarray) -> np.ndarray:
    """sqrt(sum over runs of squared errors / points found) per scan (..., K) from per-run sums (..., R, K);
    NaN where no run found a point."""
    return root_mean_square(sq, found, axis=-2)


def _mean_rms(sq: np.ndarray, found: np.ndarray) -> np.ndarray:
    """The tables' mean RMS: the mean over scans (those with a found point) of `_rms`."""
    return np.nanmean(_rms(sq, found), axis=-1)


def _stat(value: float, samples: np.ndarray, confidence: float) -> dict:
    low, high = percentile_interval(samples, confidence)
    return {"mean": float(value), "ci_low": low, "ci_high": high, "n": int(samples.size)}


def per_run_measures(trace: Trace, n_scans: int, cutoff: float) -> dict[str, float]:
    """One run's OSPA, GOSPA (means over scans, p = 2), mean |count error|, count biases (extracted, total
    weight) and the time per scan (s)."""
    t_bounds = np.searchsorted(trace.truth_scan, np.arange(1, n_scans + 2))
    e_bounds = np.searchsorted(trace.est_scan, np.arange(1, n_scans + 2))
    o, g = np.empty(n_scans), np.empty(n_scans)
    for k in range(n_scans):
        truth = trace.truth_xy[t_bounds[k]:t_bounds[k + 1]]
        est = trace.est_xy[e_bounds[k]:e_bounds[k + 1]]
        o[k], g[k] = ospa(truth, est, cutoff), gospa(truth, est, cutoff).distance
    true_count = np.diff(t_bounds)
    return {"ospa": float(o.mean()), "gospa": float(g.mean()),
            "count_error": float(np.abs(trace.extracted - true_count).mean()),
            "count_bias": float((trace.extracted - true_count).mean()),
            "weight_bias": float((trace.weight - true_count).mean()),
            "time_per_scan_s": trace.seconds / n_scans}


#: the per-run measures of the stress runs and, with the missed share and the points with 2 or more
#: estimates (``duplicates``), of the accuracy runs
PER_RUN = ("ospa", "gospa", "count_error", "count_bias", "weight_bias", "time_per_scan_s")
ACCURACY_PER_RUN = (*PER_RUN, "missed", "duplicates")
#: the mean-RMS figures of the accuracy tables
RMS_KEYS = ("x", "y", "x_punished", "y_punished")


#: the per-scan sums of `Owned` a run's record keeps
OWNED_SUMS = ("close_x", "close_y", "all_x", "all_y", "found", "points")


def score_run(trace: Trace, n_scans: int, cutoff: float, keep_estimates: bool = False) -> dict:
    """One filter's run as its record keeps it: the per-scan sums of `owned`, the estimates per true point (0, 1,
    2, 3, more), `per_run_measures` with the missed share and the points with 2 or more estimates
    (``duplicates``), the true and extracted counts and the total weight per scan, the estimates themselves
    when ``keep_estimates`` (for a density map), and the seconds stepped under ``timing``."""
    o = owned(trace, n_scans, cutoff)
    measures = per_run_measures(trace, n_scans, cutoff)
    del measures["time_per_scan_s"]  # from the timing, in `_measures`
    measures["missed"] = float(1.0 - o.found.sum() / max(o.points.sum(), 1))
    measures["duplicates"] = int((o.count >= 2).sum())
    return {"owned": {k: getattr(o, k).tolist() for k in OWNED_SUMS},
            "per_point": np.bincount(np.minimum(o.count, 4), minlength=5).tolist(), "measures": measures,
            "true_count": np.bincount(trace.truth_scan - 1, minlength=n_scans).tolist(),
            "extracted": trace.extracted.tolist(), "weight": trace.weight.tolist(),
            "estimates": trace.est_xy.tolist() if keep_estimates else None, "timing": {"seconds": trace.seconds}}


def _measures(run: dict, n_scans: int) -> dict:
    """A run record's per-run measures with its time per scan (s)."""
    return run["measures"] | {"time_per_scan_s": run["timing"]["seconds"] / n_scans}


def score_accuracy(runs: dict[str, list[dict]], n_scans: int, seed: int, bootstrap: int, confidence: float,
                   salt: int) -> dict:
    """The accuracy runs of every filter (module docstring; ``runs``: per filter label, its run records in run
    order): RMS per time (plain, punished), mean RMS with paired bootstrap intervals (``bootstrap`` resamples
    drawn from [seed, salt]) and pairwise differences, per-run measures with t-intervals, estimate counts."""
    labels = list(runs)
    R = len(runs[labels[0]])
    idx = bootstrap_indices([seed, salt], R, bootstrap)
    out: dict = {"runs": R, "n_scans": n_scans, "filters": {}, "differences": []}
    boot, per_run = {}, {}
    for f in labels:
        stack = {k: np.array([r["owned"][k] for r in runs[f]]) for k in OWNED_SUMS}
        found = stack["found"]
        rec: dict = {"rms": {}, "mean_rms": {}}
        for axis in ("x", "y"):
            close, every = stack[f"close_{axis}"], stack[f"all_{axis}"]
            rec["rms"][axis] = [None if not math.isfinite(v) else float(v) for v in _rms(close, found)]
            rec["rms"][f"{axis}_punished"] = [None if not math.isfinite(v) else float(v) for v in _rms(every, found)]
            for key, sq in ((axis, close), (f"{axis}_punished", every)):
                boot[f, key] = _mean_rms(sq[idx], found[idx])
                rec["mean_rms"][key] = _stat(_mean_rms(sq, found), boot[f, key], confidence)
        per_run[f] = [_measures(r, n_scans) for r in runs[f]]
        rec["per_run"] = {k: mean_ci([r[k] for r in per_run[f]], confidence) for k in ACCURACY_PER_RUN}
        counts = np.array([r["per_point"] for r in runs[f]])  # (R, 5)
        rec["estimates_per_point"] = {name: {"total": int(counts[:, i].sum()),
                                             "per_run": mean_ci(counts[:, i].tolist(), confidence)}
                                      for i, name in ((0, "0"), (1, "1"), (2, "2"), (3, "3"), (4, ">3"))}
        rec["true_points"] = int(counts.sum())
        out["filters"][f] = rec
    rms = out["filters"]
    for i, a in enumerate(labels):
        for b in labels[i + 1:]:
            out["differences"].append({"a": a, "b": b, **{
                key: _stat(rms[a]["mean_rms"][key]["mean"] - rms[b]["mean_rms"][key]["mean"],
                           boot[a, key] - boot[b, key], confidence) for key in RMS_KEYS}, **{
                key: mean_ci([ra[key] - rb[key] for ra, rb in zip(per_run[a], per_run[b], strict=True)],
                             confidence) for key in ACCURACY_PER_RUN}})
    return out


def score_stress(runs: dict[str, list[dict]], n_scans: int, confidence: float) -> dict:
    """The stress runs of every filter (per filter label, its run records): per-run measures with t-intervals,
    the target counts per scan (mean over runs: truth, extracted, total weight) and the runtime per run."""
    out: dict = {"runs": len(next(iter(runs.values()))), "n_scans": n_scans, "filters": {}}
    for f, rs in runs.items():
        per = [_measures(r, n_scans) for r in rs]
        out["filters"][f] = {
            "per_run": {k: mean_ci([r[k] for r in per], confidence) for k in PER_RUN},
            "runtime_s": mean_ci([r["timing"]["seconds"] for r in rs], confidence),
            "count": {"truth": np.array([r["true_count"] for r in rs]).mean(axis=0).tolist(),
                      "extracted": np.mean([r["extracted"] for r in rs], axis=0).tolist(),
                      "weight": np.mean([r["weight"] for r in rs], axis=0).tolist()},
        }
    return out


def density(runs: list[dict], width_m: float, height_m: float, cell_m: float = 1.0) -> dict:
    """The estimates of every run (records kept with their estimates) binned on the map (Fig. 6.19): counts per
    cell (rows = y)."""
    xy = np.concatenate([np.asarray(r["estimates"], dtype=float).reshape(-1, 2) for r in runs]).reshape(-1, 2)
    h, _, _ = np.histogram2d(xy[:, 1], xy[:, 0], bins=(round(height_m / cell_m), round(width_m / cell_m)),
                             range=((0, height_m), (0, width_m)))
    return {"cell_m": cell_m, "width_m": width_m, "height_m": height_m, "counts": h.astype(int).tolist()}


#: Test 1: draws per profile, the polar histograms' profiles, the pdf curves' and the variance sweep's
TEST1_DRAWS = 10_000
TEST1_HISTOGRAMS = (("drop", 10.0), ("leaf", 3.0), ("balloon", 1.0))
TEST1_PDFS = {"drop": (1.5, math.pi, 5.0, 10.0), "leaf": (0.9, 1.0, math.pi, 5.0), "balloon": (0.45, 0.55, 0.65, 0.75)}
TEST1_VARIANCE = {"drop": (2.0, 10.0, 50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0, 400.0, 1000.0),
                  "leaf": (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 7.0, 10.0), "balloon": (0.1, 0.25, 0.5, 0.75, 1.0)}
#: bins of Test 1's polar histograms over [-pi, pi)
TEST1_BINS = 36


def run_test1(seed: int, confidence: float) -> dict:
    """Test 1, the profiles' objectivity: for each profile and parameter of `TEST1_VARIANCE`, the closed-form
    variance beside that of TEST1_DRAWS draws (t-interval of the mean of delta^2; the mean is 0); the polar
    histograms of TEST1_DRAWS draws (wrapped to [-pi, pi)) and the pdf curves of the thesis's figures."""
    rng = np.random.default_rng([seed, 1])
    grid = np.linspace(-np.pi, np.pi, 361)
    variance = {kind: [{"parameter": p, "closed": HeadingProfile(kind, p).variance(),
                        "sampled": mean_ci(HeadingProfile(kind, p).sample(rng, TEST1_DRAWS) ** 2, confidence)}
                       for p in params] for kind, params in TEST1_VARIANCE.items()}
    histograms = []
    for kind, p in TEST1_HISTOGRAMS:
        d = (HeadingProfile(kind, p).sample(rng, TEST1_DRAWS) + np.pi) % (2 * np.pi) - np.pi
        counts, _ = np.histogram(d, bins=TEST1_BINS, range=(-np.pi, np.pi))
        histograms.append({"kind": kind, "parameter": p, "counts": counts.tolist()})
    pdfs = {kind: [{"parameter": p, "density": HeadingProfile(kind, p).density(grid).tolist()} for p in params]
            for kind, params in TEST1_PDFS.items()}
    return {"draws": TEST1_DRAWS, "variance": variance, "histograms": histograms, "grid": grid.tolist(),
            "pdfs": pdfs}
