"""seed-000's pedestrian study (Frencl 2014, Tests 2-4): PHD filters on simulated walkers, with intervals.

Test 1 (spec §4.2) draws the heading profiles (`run_test1`: their variance
against the objectivity parameter, closed form beside 10,000 draws, polar
histograms and pdf curves). Each later test runs its filters on the same
Monte Carlo runs of its scenes
(`nnda.data.pedestrian.scenes`; every filter sees the same contacts)::

    cfg = PedestrianStudyConfig()             # Tests 1-4, 300 / 600 / 25 runs, measurement-driven birth
    results = run_pedestrian_study(cfg)       # a JSON-ready dict (RESULTS_FORMAT, version 1)

(`nnda pedestrian`, in `nnda.reports.pedestrian_section`, writes it and its report atomically; the
wall-clock entries go to their own file, `split_timing`, so the results file is the same, byte for byte,
for the same config and seed.)

* Test 2 (Tables 6.1, 6.2, Fig. 6.8): GM-PHD + CV, EK-PHD and UK-PHD +
  modified NCSHT; accuracy on ``walk-test2`` (one walker, the same
  trajectory in every run), target count and runtime on ``walk-stress``.
* Test 3 (Tables 6.3, 6.4): the EK-PHD with CV, modified NCSHT and the
  HM-map composite on the "+" map (``walk-test3``, ``walk-test3-stress``).
* Test 4 (Table 6.5, Fig. 6.19): the EK-PHD with modified NCSHT without
  and with the corridor's HM map on ``walk-test4`` (a new trajectory per run).

Every filter takes the thesis's parameter block (spec §4.1: reduction set
``seed-000``, p_D = p_S = 0.99, the ground radar's R, spawn weight 0.05 with
covariance Q(1 s)), clutter lambda = 2e-3 per m^2 times the map's area,
spread over the map (``clutter_area_m2``), and measurement-driven birth
(rate 0.1 per scan, newborn speed 0 +/- 1.5 m/s per axis); ``birth =
"oracle"`` is the thesis's: weight-0.1 components at the walkers' true
first states, B = diag(2^2, 2^2, 1.5^2, 1.36^2) in [x y vx vy] or [x y v
alpha], at the first scan only (reported as its own study).

Scoring (our reading where the thesis is vague, spec §5 and §8.10): an
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
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from threadpoolctl import threadpool_limits

from nnda.data.dataset import Dataset
from nnda.data.pedestrian.profiles import HeadingProfile
from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.pedestrian.walkers import WalkerScene, walker_runs
from nnda.errors import validated
from nnda.filters.ground_motion import ThesisCV
from nnda.filters.imm import IMM
from nnda.filters.measurement import measurement_model
from nnda.study.gospa import gospa, ospa
from nnda.study.stats import bootstrap_indices, mean_ci, percentile_interval, root_mean_square
from nnda.tracking.output import CONFIRMED
from nnda.tracking.registry import TRACKERS, make_tracker
from nnda.tracking.tracker import Tracker

RESULTS_FORMAT = "nnda-pedestrian-study"
RESULTS_VERSION = 1
RESULTS_FILE = "results.json"
TIMING_FILE = "timing.json"
TESTS = ("test1", "test2", "test3", "test4")
#: the thesis's birth covariance diag (spec §4.1) in its [x y vx vy] / [x y v alpha] order
BIRTH_STD = (2.0, 2.0, 1.5, 1.36)
#: the thesis's birth and spawn weights (spec §4.1)
BIRTH_WEIGHT, SPAWN_WEIGHT = 0.1, 0.05
#: measurement-driven birth: expected births per scan and the newborn's speed std per axis (m/s; ours)
BIRTH_RATE, BIRTH_SPEED_SIGMA = 0.1, 1.5
#: seed-000's unscented central weight W0 = 2/3 is kappa = 2 n for n = 4 (`nnda.filters.unscented`)
UKF_KAPPA = 8.0
#: the motions whose state is [x, y, v, alpha] (the oracle birth's layout)
HEADING = ("ncsht-seed-000", "hm-map")
#: the PHD trackers (the others are contact trackers: `contact_tracker`)
PHD_KINDS = ("gmphd", "ekphd", "ukphd", "cphd")
#: the contact trackers' initiation window tops at this speed (m/s; person set A's fastest: 2 + 2 x 1)
WALKER_MAX_SPEED_M_S = 4.5

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@dataclass(frozen=True)
class FilterSpec:
    """One filter of a test: report label, tracker kind, motion and its extra tracker parameters."""

    label: str
    kind: str
    motion: str
    extra: tuple[tuple[str, object], ...] = ()


_GM_CV = FilterSpec("GM-PHD + CV", "gmphd", "cv-seed-000")
_EK_NC = FilterSpec("EK-PHD + NCSHT", "ekphd", "ncsht-seed-000")
_UK_NC = FilterSpec("UK-PHD + NCSHT", "ukphd", "ncsht-seed-000", (("unscented", {"kappa": UKF_KAPPA}),))


@dataclass(frozen=True)
class TestSpec:
    """A test: its accuracy scene, its stress scene (None: none), its filters, which config field sets its
    accuracy runs."""

    name: str
    title: str
    accuracy: str
    stress: str | None
    filters: tuple[FilterSpec, ...]
    runs_field: str


TEST_SPECS = {t.name: t for t in (
    TestSpec("test2", "Test 2: GM-PHD + CV vs EK-PHD and UK-PHD + modified NCSHT", "walk-test2", "walk-stress",
             (_GM_CV, _EK_NC, _UK_NC), "runs"),
    TestSpec("test3", "Test 3: the EK-PHD with CV, modified NCSHT and the HM-map model on the '+' map",
             "walk-test3", "walk-test3-stress",
             (FilterSpec("EK-PHD + CV", "ekphd", "cv-seed-000"), _EK_NC,
              FilterSpec("EK-PHD + NCSHT + HM map", "ekphd", "hm-map", (("hm_map", "plus"),))), "runs"),
    TestSpec("test4", "Test 4: the EK-PHD without and with the HM map in the corridor", "walk-test4", None,
             (FilterSpec("EK-PHD, no HM map", "ekphd", "ncsht-seed-000"),
              FilterSpec("EK-PHD, HM map", "ekphd", "hm-map", (("hm_map", "corridor"),))), "test4_runs"),
)}
#: beyond the thesis: nnda's contact trackers and the CPHD on the stress scene's walkers, beside two of its PHDs
BEYOND = (_GM_CV, _EK_NC, FilterSpec("CPHD + CV", "cphd", "cv-seed-000"), FilterSpec("GNN", "gnn", "cv-seed-000"),
          FilterSpec("JPDA", "jpda", "cv-seed-000"), FilterSpec("MHT", "mht", "cv-seed-000"))
BEYOND_SCENE = "walk-stress"


class PedestrianStudyConfig(BaseModel):
    """The study: which ``tests`` and whether the comparison ``beyond`` the thesis, accuracy ``runs`` of Tests
    2-3 and ``test4_runs`` of Test 4,
    ``stress_runs`` of the stress scenes (target count, runtime), ``seed``, ``birth``, the cut-off
    ``cutoff_m``, ``bootstrap`` resamples, the intervals' ``confidence`` and worker processes ``jobs``."""

    model_config = _STRICT

    tests: Annotated[tuple[Literal["test1", "test2", "test3", "test4"], ...], Field(min_length=1)] = TESTS
    beyond: bool = True
    runs: Annotated[int, Field(ge=2)] = 300
    test4_runs: Annotated[int, Field(ge=2)] = 600
    stress_runs: Annotated[int, Field(ge=2)] = 25
    seed: Annotated[int, Field(ge=0)] = 0
    birth: Literal["measurement", "oracle"] = "measurement"
    cutoff_m: Annotated[float, Field(gt=0)] = 2.0
    bootstrap: Annotated[int, Field(ge=100)] = 1000
    confidence: Annotated[float, Field(gt=0, lt=1)] = 0.95
    jobs: Annotated[int, Field(ge=1)] = 1


# ----------------------------------------------------------------------------- one run


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


def filter_params(f: FilterSpec, scene: WalkerScene, birth: str, dataset: Dataset | None = None) -> dict:
    """The tracker parameters of filter ``f`` on ``scene`` (module docstring); ``birth`` "oracle" needs the
    run's ``dataset`` (its walkers' first states)."""
    area = scene.map.width_m * scene.map.height_m
    params: dict = {"preset": "seed-000", "motion": f.motion, "pd": 0.99, "ps": 0.99,
                    "clutter": scene.radar.clutter_per_m2 * area, "clutter_area_m2": area, **dict(f.extra)}
    if f.kind != "cphd":  # the CPHD has no spawning
        motion = TRACKERS[f.kind].config_type(**params).motion_model()
        params["spawn"] = {"weight": SPAWN_WEIGHT,
                           "covariance": motion.noise(np.asarray(scene.scan_period_s)).tolist()}
    if birth == "measurement":
        params["birth"] = {"kind": "measurement", "rate": BIRTH_RATE, "speed_sigma_m_s": BIRTH_SPEED_SIGMA}
        return params
    t = dataset.truth
    first = t.scan == t.scan.min()
    x, y, vx, vy = t.x[first], t.y[first], t.vx[first], t.vy[first]
    if f.motion in HEADING:
        means = np.column_stack([x, y, np.hypot(vx, vy), np.arctan2(vy, vx)])
    else:
        means = np.column_stack([x, vx, y, vy])
    sx, sy, sv, sa = BIRTH_STD
    cov = np.diag([sx**2, sy**2, sv**2, sa**2]) if f.motion in HEADING else np.diag([sx**2, sv**2, sy**2, sa**2])
    params["birth"] = {"kind": "static", "every_scan": False, "components": [
        {"weight": BIRTH_WEIGHT, "mean": m.tolist(), "covariance": cov.tolist()} for m in means]}
    return params


def contact_tracker(f: FilterSpec, scene: WalkerScene, sensors: tuple) -> Tracker:
    """A contact tracker for walkers (the comparison beyond the thesis): the thesis's CV as a one-model IMM,
    the ground radar's p_D and clutter density, an initiation window of 0-``WALKER_MAX_SPEED_M_S``."""
    params: dict = {"lifecycle": {"v_min": 0.0, "v_max": WALKER_MAX_SPEED_M_S}, **dict(f.extra)}
    if f.kind in ("jpda", "mht"):
        params |= {"pd": scene.radar.pd, "clutter_density": scene.radar.clutter_per_m2}
    cls = TRACKERS[f.kind]
    config = validated(cls.config_type, params, f.label, f"{f.kind} config")
    imm = IMM(models=(ThesisCV(),), measurement=measurement_model(sensors[0]), tpm=((1.0,),), mu0=(1.0,))
    return cls(sensors, config, track_filter=imm)


def track(f: FilterSpec, scene: WalkerScene, dataset: Dataset, birth: str) -> Trace:
    """Run filter ``f`` through one run's scans (one BLAS thread), timing each step; a contact tracker's
    confirmed tracks are its estimates (its weight: their number)."""
    with threadpool_limits(1):
        sensors = dataset.scenario.sensors
        phd = f.kind in PHD_KINDS
        tracker = (make_tracker(f.kind, sensors, filter_params(f, scene, birth, dataset)) if phd else
                   contact_tracker(f, scene, sensors))
        scans, xy, extracted, weight, seconds = [], [], [], [], 0.0
        for scan in dataset.scans():
            start = time.perf_counter()
            out = tracker.step(scan)
            seconds += time.perf_counter() - start
            state = out.state[out.status == CONFIRMED]
            scans.append(np.full(len(state), scan.index))
            xy.append(state[:, [0, 2]])
            extracted.append(len(state))
            weight.append(tracker.cardinality.mean if phd else len(state))
    t = dataset.truth
    return Trace(t.scan.astype(np.int64), np.column_stack([t.x, t.y]), np.concatenate(scans).astype(np.int64),
                 np.concatenate(xy).reshape(-1, 2), np.array(extracted), np.array(weight), seconds)


def _traces(work: tuple[str, int, tuple[int, ...], tuple[FilterSpec, ...], str]) -> list[list[Trace]]:
    """A worker's share: every filter on runs ``runs`` of scene ``name`` (seed ``seed``), each run simulated
    once for all of them; per filter, its traces in run order."""
    name, seed, runs, filters, birth = work
    scene = PEDESTRIAN_SCENES[name]
    out: list[list[Trace]] = [[] for _ in filters]
    for ds in walker_runs(scene, runs, seed):
        for traces, f in zip(out, filters, strict=True):
            traces.append(track(f, scene, ds, birth))
    return out


def run_traces(name: str, filters: tuple[FilterSpec, ...], runs: int, cfg: PedestrianStudyConfig
               ) -> dict[str, list[Trace]]:
    """Every filter on runs 0..runs-1 of scene ``name``, the runs split over ``cfg.jobs`` processes; by
    label, in run order (the same for any number of processes)."""
    chunks = [c for c in np.array_split(np.arange(runs), cfg.jobs) if len(c)]
    work = [(name, cfg.seed, tuple(int(r) for r in c), filters, cfg.birth) for c in chunks]
    if cfg.jobs == 1:
        done = [_traces(w) for w in work]
    else:
        with ProcessPoolExecutor(cfg.jobs) as pool:
            done = list(pool.map(_traces, work))
    return {f.label: [t for part in done for t in part[i]] for i, f in enumerate(filters)}


# ----------------------------------------------------------------------------- scoring


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


def score_accuracy(traces: dict[str, list[Trace]], n_scans: int, cfg: PedestrianStudyConfig, salt: int) -> dict:
    """The accuracy runs of every filter (module docstring): RMS per time (plain, punished), mean RMS with
    paired bootstrap intervals and pairwise differences, per-run measures with t-intervals, estimate counts."""
    labels = list(traces)
    own = {f: [owned(t, n_scans, cfg.cutoff_m) for t in traces[f]] for f in labels}
    R = len(traces[labels[0]])
    idx = bootstrap_indices([cfg.seed, salt], R, cfg.bootstrap)
    out: dict = {"runs": R, "n_scans": n_scans, "filters": {}, "differences": []}
    boot, per_run = {}, {}
    for f in labels:
        stack = {k: np.array([getattr(o, k) for o in own[f]]) for k in ("close_x", "close_y", "all_x", "all_y",
                                                                         "found", "points")}
        found = stack["found"]
        rec: dict = {"rms": {}, "mean_rms": {}}
        for axis in ("x", "y"):
            close, every = stack[f"close_{axis}"], stack[f"all_{axis}"]
            rec["rms"][axis] = [None if not math.isfinite(v) else float(v) for v in _rms(close, found)]
            rec["rms"][f"{axis}_punished"] = [None if not math.isfinite(v) else float(v) for v in _rms(every, found)]
            for key, sq in ((axis, close), (f"{axis}_punished", every)):
                boot[f, key] = _mean_rms(sq[idx], found[idx])
                rec["mean_rms"][key] = _stat(_mean_rms(sq, found), boot[f, key], cfg.confidence)
        runs = [per_run_measures(t, n_scans, cfg.cutoff_m) for t in traces[f]]
        for r, o in zip(runs, own[f], strict=True):
            r["missed"] = float(1.0 - o.found.sum() / max(o.points.sum(), 1))
            r["duplicates"] = int((o.count >= 2).sum())
        per_run[f] = runs
        rec["per_run"] = {k: mean_ci([r[k] for r in runs], cfg.confidence) for k in ACCURACY_PER_RUN}
        counts = np.array([np.bincount(np.minimum(o.count, 4), minlength=5) for o in own[f]])  # (R, 5)
        rec["estimates_per_point"] = {name: {"total": int(counts[:, i].sum()),
                                             "per_run": mean_ci(counts[:, i].tolist(), cfg.confidence)}
                                      for i, name in ((0, "0"), (1, "1"), (2, "2"), (3, "3"), (4, ">3"))}
        rec["true_points"] = int(counts.sum())
        out["filters"][f] = rec
    rms = out["filters"]
    for i, a in enumerate(labels):
        for b in labels[i + 1:]:
            out["differences"].append({"a": a, "b": b, **{
                key: _stat(rms[a]["mean_rms"][key]["mean"] - rms[b]["mean_rms"][key]["mean"],
                           boot[a, key] - boot[b, key], cfg.confidence) for key in RMS_KEYS}, **{
                key: mean_ci([ra[key] - rb[key] for ra, rb in zip(per_run[a], per_run[b], strict=True)],
                             cfg.confidence) for key in ACCURACY_PER_RUN}})
    return out


def score_stress(traces: dict[str, list[Trace]], n_scans: int, cfg: PedestrianStudyConfig) -> dict:
    """The stress runs of every filter: per-run measures with t-intervals, the target counts per scan
    (mean over runs: truth, extracted, total weight) and the runtime per run."""
    out: dict = {"runs": len(next(iter(traces.values()))), "n_scans": n_scans, "filters": {}}
    for f, ts in traces.items():
        runs = [per_run_measures(t, n_scans, cfg.cutoff_m) for t in ts]
        true_count = np.array([np.bincount(t.truth_scan - 1, minlength=n_scans) for t in ts])
        out["filters"][f] = {
            "per_run": {k: mean_ci([r[k] for r in runs], cfg.confidence) for k in PER_RUN},
            "runtime_s": mean_ci([t.seconds for t in ts], cfg.confidence),
            "count": {"truth": true_count.mean(axis=0).tolist(),
                      "extracted": np.mean([t.extracted for t in ts], axis=0).tolist(),
                      "weight": np.mean([t.weight for t in ts], axis=0).tolist()},
        }
    return out


def density(traces: list[Trace], width_m: float, height_m: float, cell_m: float = 1.0) -> dict:
    """The estimates of every run binned on the map (Fig. 6.19): counts per cell (rows = y)."""
    xy = np.concatenate([t.est_xy for t in traces]).reshape(-1, 2)
    h, _, _ = np.histogram2d(xy[:, 1], xy[:, 0], bins=(round(height_m / cell_m), round(width_m / cell_m)),
                             range=((0, height_m), (0, width_m)))
    return {"cell_m": cell_m, "width_m": width_m, "height_m": height_m, "counts": h.astype(int).tolist()}


def run_test(spec: TestSpec, cfg: PedestrianStudyConfig, salt: int) -> dict:
    """One test: its accuracy runs and, when it has one, its stress scene."""
    scene = PEDESTRIAN_SCENES[spec.accuracy]
    t0 = time.perf_counter()
    traces = run_traces(spec.accuracy, spec.filters, getattr(cfg, spec.runs_field), cfg)
    result = {"name": spec.name, "title": spec.title, "accuracy_scene": spec.accuracy,
              "filters": {f.label: {"kind": f.kind, "motion": f.motion, **dict(f.extra)} for f in spec.filters},
              "accuracy": score_accuracy(traces, scene.n_scans, cfg, salt)}
    if spec.name == "test4":
        result["density"] = {f: density(ts, scene.map.width_m, scene.map.height_m) for f, ts in traces.items()}
    if spec.stress is not None:
        stress = PEDESTRIAN_SCENES[spec.stress]
        result["stress_scene"] = spec.stress
        result["stress"] = score_stress(run_traces(spec.stress, spec.filters, cfg.stress_runs, cfg),
                                        stress.n_scans, cfg)
    result["runtime_s"] = time.perf_counter() - t0
    return result


#: Test 1 (spec §4.2): draws per profile, the polar histograms' profiles, the pdf curves' and the variance sweep's
TEST1_DRAWS = 10_000
TEST1_HISTOGRAMS = (("drop", 10.0), ("leaf", 3.0), ("balloon", 1.0))
TEST1_PDFS = {"drop": (1.5, math.pi, 5.0, 10.0), "leaf": (0.9, 1.0, math.pi, 5.0), "balloon": (0.45, 0.55, 0.65, 0.75)}
TEST1_VARIANCE = {"drop": (2.0, 10.0, 50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0, 400.0, 1000.0),
                  "leaf": (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 7.0, 10.0), "balloon": (0.1, 0.25, 0.5, 0.75, 1.0)}
#: bins of Test 1's polar histograms over [-pi, pi)
TEST1_BINS = 36


def run_test1(cfg: PedestrianStudyConfig) -> dict:
    """Test 1, the profiles' objectivity: for each profile and parameter of `TEST1_VARIANCE`, the closed-form
    variance beside that of TEST1_DRAWS draws (t-interval of the mean of delta^2; the mean is 0); the polar
    histograms of TEST1_DRAWS draws (wrapped to [-pi, pi)) and the pdf curves of the thesis's figures."""
    rng = np.random.default_rng([cfg.seed, 1])
    grid = np.linspace(-np.pi, np.pi, 361)
    variance = {kind: [{"parameter": p, "closed": HeadingProfile(kind, p).variance(),
                        "sampled": mean_ci(HeadingProfile(kind, p).sample(rng, TEST1_DRAWS) ** 2, cfg.confidence)}
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


#: the wall-clock entries of a results document (they change between two runs of the same study)
TIMING_KEYS = ("runtime_s", "time_per_scan_s")


def split_timing(doc):
    """``doc`` (nested dicts and lists) without its `TIMING_KEYS` entries, and those entries in the same
    nesting (lists keep their positions, {} where nothing was timed): the first is the same for the same
    config and seed, byte for byte."""
    if isinstance(doc, dict):
        kept, timing = {}, {}
        for k, v in doc.items():
            if k in TIMING_KEYS:
                timing[k] = v
                continue
            kept[k], t = split_timing(v)
            if t:
                timing[k] = t
        return kept, timing
    if isinstance(doc, list):
        parts = [split_timing(v) for v in doc]
        timed = [t for _, t in parts]
        return [k for k, _ in parts], (timed if any(timed) else {})
    return doc, {}


def join_timing(doc, timing):
    """The inverse of `split_timing`: ``doc`` with ``timing``'s entries put back."""
    if isinstance(doc, dict) and isinstance(timing, dict):
        out = {k: join_timing(v, timing.get(k, {})) for k, v in doc.items()}
        return out | {k: v for k, v in timing.items() if k in TIMING_KEYS}
    if isinstance(doc, list) and isinstance(timing, list):
        return [join_timing(d, t) for d, t in zip(doc, timing, strict=True)]
    return doc


def run_pedestrian_study(cfg: PedestrianStudyConfig) -> dict:
    """Every test of ``cfg``; the results document (format RESULTS_FORMAT)."""
    t0 = time.perf_counter()
    tests = [run_test(TEST_SPECS[name], cfg, i) for i, name in enumerate(cfg.tests) if name in TEST_SPECS]
    out = {"format": RESULTS_FORMAT, "version": RESULTS_VERSION, "config": cfg.model_dump(mode="json"),
           "tests": tests}
    if "test1" in cfg.tests:
        out["test1"] = run_test1(cfg)
    if cfg.beyond:
        out["beyond"] = {"scene": BEYOND_SCENE, **score_stress(run_traces(BEYOND_SCENE, BEYOND, cfg.stress_runs, cfg),
                                                               PEDESTRIAN_SCENES[BEYOND_SCENE].n_scans, cfg)}
    return out | {"runtime_s": time.perf_counter() - t0}
