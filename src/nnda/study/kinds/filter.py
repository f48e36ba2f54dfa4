"""The ``filter`` kind: single-target filters (`nnda.filters.single_target`) on the study's single-target
scenarios, each fed the target's own contacts (the generator's labels pick them: no association)::

    [filters.imm-cv]          # a label of your choice -> a registered filter
    kind = "imm"
    params = { motion = "cv" }

A job is one filter over one run of one single-target scenario (the
study's ``[[scenarios]]`` with one target); its record holds every measure
of `nnda.study.measures` (the run value, and the per-scan series of
the per-scan ones) and the time of each step. The aggregates:
``filter_results.parquet`` (one row per job) and, in ``summary.json``, a
``filters`` list (per scenario and filter, mean and t-interval of each
measure, per-scan means); the filters' time per scan goes to ``timing.json``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
import pyarrow as pa
from pydantic import BaseModel, Field
from threadpoolctl import threadpool_limits

from nnda.data.sources import GeneratedScenes, StoredDatasets, WalkerScenes
from nnda.errors import ConfigError
from nnda.files import finite_or_none
from nnda.filters.single_target import make_filter
from nnda.study.filter_run import FilterRun
from nnda.study.kinds.base import STRICT, Job, JobKind, Label, job_key
from nnda.study.kinds.track import relpath, scenario_plans, sensor_setups
from nnda.study.measures import FILTER_MEASURES, FILTER_SERIES, time_summary
from nnda.study.stats import mean_ci, ragged_mean
from nnda.study.track_job import dataset_digest

FILTER_RESULTS_FILE = "filter_results.parquet"


class FilterSpec(BaseModel):
    """One single-target filter of the study: a registered kind and its parameters."""

    model_config = STRICT

    kind: Annotated[str, Field(min_length=1, description="registered filter name (nnda.filters.single_target)")]
    params: dict[str, Any] = Field(default_factory=dict, description="the filter's config")


FIELDS = {"filters": (dict[Label, FilterSpec], Field(default_factory=dict, description="single-target filters: jobs "
                                                     "on the study's single-target scenarios"))}


def check(study) -> None:
    both = sorted(set(study.trackers) & set(study.filters))
    if both:
        raise ValueError(f"label(s) {', '.join(both)} name both a tracker and a filter; labels must differ")


@dataclass(frozen=True)
class FilterPlan:
    """A single-target filter of the study and the single-target scenarios it runs on."""

    label: str
    kind: str
    params: dict
    scenarios: tuple[str, ...]


@dataclass(frozen=True)
class FilterJob:
    """One filter over one run of one single-target scenario."""

    scenario: str
    label: str
    run: int
    kind: str
    params: dict
    seed: int
    source: GeneratedScenes | StoredDatasets | WalkerScenes


@dataclass(frozen=True)
class FiltersPlan:
    """The checked filter part of a study: the filters, their scenarios (name, runs) and jobs."""

    study: Any
    filters: tuple[FilterPlan, ...]
    scenarios: tuple[tuple[str, int], ...]
    jobs: tuple[Job, ...]

    def manifest(self) -> dict:
        return {}  # the study's [filters] table is in the manifest's study


def plan(study, where: str) -> FiltersPlan:
    """The study's filters, each built once per distinct set of sensors (validates kind and params), and their
    jobs on the single-target scenarios."""
    scenarios = scenario_plans(study, where)
    single = tuple(sc for sc in scenarios if len(sc.scenario.targets) == 1)
    if not single:
        counts = ", ".join(f"{sc.name} ({len(sc.scenario.targets)})" for sc in scenarios)
        raise ConfigError(f"{where}: filters run on single-target scenarios, and this study has none "
                          f"(targets per scenario: {counts})")
    filters = []
    for label, spec in study.filters.items():
        for setup in sensor_setups(single):
            make_filter(spec.kind, setup, spec.params, where=f"{where}: filter {label!r}")
        filters.append(FilterPlan(label, spec.kind, dict(spec.params), tuple(sc.name for sc in single)))
    jobs = []
    for sc in single:
        for run in range(sc.runs):
            for f in filters:
                key = job_key({"task": "filter", "scenario": sc.name, "data": sc.source.digest(run),
                               "filter": f.label, "kind": f.kind, "params": f.params, "run": run, "seed": study.seed})
                spec = FilterJob(sc.name, f.label, run, f.kind, f.params, study.seed, sc.source)
                jobs.append(Job("filter", key, relpath(sc.name, f.label, run), f"{f.label} on {sc.name} run {run}",
                                spec))
    return FiltersPlan(study, tuple(filters), tuple((sc.name, sc.runs) for sc in single), tuple(jobs))


def _run_value(series: np.ndarray) -> float:
    """A per-scan filter measure's run value: its mean over the scans where it is defined (NaN if none)."""
    finite = series[np.isfinite(series)]
    return float(finite.mean()) if finite.size else float("nan")


def run(job: FilterJob) -> dict:
    """A filter job's record: the filter through the target's own contacts, scored against the truth."""
    with threadpool_limits(1):
        dataset = job.source.load(job.run, 1, job.seed)[0]
        f = make_filter(job.kind, dataset.scenario.sensors, job.params)
        truth, bounds = dataset.truth, dataset.scan_bounds()
        own = dataset.detections.target_id == 0
        rows = np.flatnonzero(truth.target_id == 0)  # the scans where the target exists, in scan order
        alive = set(truth.scan[rows].tolist())
        x, P = np.full((len(rows), 4), np.nan), np.full((len(rows), 4, 4), np.nan)
        seconds = np.empty(len(rows))
        i = 0
        for scan in dataset.scans():
            if scan.index not in alive:
                continue
            mine = np.flatnonzero(own[bounds[scan.index - 1]:bounds[scan.index]])  # at most one contact per scan
            start = time.perf_counter()
            est = f.step(float(scan.time), scan.sensor, scan.measurements[mine[0]] if mine.size else None)
            seconds[i] = time.perf_counter() - start
            if est is not None:
                x[i], P[i] = est.x, est.P
            i += 1
    result = FilterRun(dataset.scan_time[truth.scan[rows] - 1], x, P,
                       np.column_stack([truth.x[rows], truth.vx[rows], truth.y[rows], truth.vy[rows]]))
    values = {m.key: m.of("filter", result) for m in FILTER_MEASURES}
    return {
        "scenario": job.scenario, "tracker": job.label, "kind": job.kind, "run": job.run, "seed": job.seed,
        "dataset_digest": dataset_digest(dataset), "n_scans": dataset.n_scans, "n_targets": 1,
        "metrics": {m.key: finite_or_none(_run_value(values[m.key]) if m.per_scan else values[m.key])
                    for m in FILTER_MEASURES},
        "series": {m.series_name: [finite_or_none(float(v)) for v in values[m.key]] for m in FILTER_SERIES},
        "timing": {"time_per_scan_s": seconds.tolist()},
    }


def results_table(records: list[dict]) -> pa.Table:
    """One row per filter job: scenario, filter, kind, run, seed, dataset digest, every filter measure."""
    cols: dict[str, pa.Array] = {
        "scenario": pa.array([r["scenario"] for r in records], pa.string()),
        "filter": pa.array([r["tracker"] for r in records], pa.string()),
        "kind": pa.array([r["kind"] for r in records], pa.string()),
        "run": pa.array([r["run"] for r in records], pa.int32()),
        "seed": pa.array([r["seed"] for r in records], pa.int64()),
        "dataset_digest": pa.array([r["dataset_digest"] for r in records], pa.string()),
    }
    for m in FILTER_MEASURES:
        cols[m.key] = pa.array([r["metrics"][m.key] for r in records], pa.float64())
    for m in FILTER_SERIES:
        cols[f"{m.series_name}_per_scan"] = pa.array([r["series"][m.series_name] for r in records],
                                                     type=pa.list_(pa.float64()))
    return pa.table(cols)


def aggregate(plan: FiltersPlan, records: list[dict]) -> tuple[dict, dict, dict[str, pa.Table]]:
    """``summary.json``'s ``filters`` (per single-target scenario and filter: mean and t-interval of each measure,
    per-scan means), ``timing.json``'s ``filters`` (time per scan) and ``filter_results.parquet`` (rows in
    scenario, filter, run order)."""
    scenario = {name: i for i, (name, _) in enumerate(plan.scenarios)}
    label = {f.label: i for i, f in enumerate(plan.filters)}
    records = sorted(records, key=lambda r: (scenario[r["scenario"]], label[r["tracker"]], r["run"]))
    conf = plan.study.confidence
    summary, timing = [], []
    for name, runs in plan.scenarios:
        filters, times = {}, {}
        for f in plan.filters:
            mine = [r for r in records if r["scenario"] == name and r["tracker"] == f.label]
            filters[f.label] = {
                "kind": f.kind, "runs": len(mine),
                "metrics": {m.key: mean_ci([r["metrics"][m.key] for r in mine], conf, *m.bounds)
                            for m in FILTER_MEASURES},
                "series_mean": {m.series_name: ragged_mean([r["series"][m.series_name] for r in mine])
                                for m in FILTER_SERIES},
            }
            times[f.label] = time_summary([r["timing"]["time_per_scan_s"] for r in mine], conf)
        summary.append({"name": name, "runs": runs, "filters": filters})
        timing.append({"name": name, "filters": times})
    return {"filters": summary}, {"filters": timing}, {FILTER_RESULTS_FILE: results_table(records)}


KIND = JobKind(name="filter", fields=FIELDS, work="[filters.<label>]", given=lambda study: bool(study.filters),
               plan=plan, run=run, aggregate=aggregate, check=check)
