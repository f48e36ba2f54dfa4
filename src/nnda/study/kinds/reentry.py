"""The ``reentry`` kind: particle filters and Gaussian baselines on ballistic re-entry runs (Pavlov & Bruno
2003; `nnda.study.reentry`). Its table holds `nnda.study.reentry.ReentryStudyConfig`'s fields but the seed
and confidence, which are the study's::

    [reentry]
    runs = 100
    steps = 55
    [[reentry.settings]]
    name = "paper"
    sigma_r = 200.0
    sigma_eps = 0.017
    particles = [4000]

A job is one filter at one particle count on every run of one setting
(the batching over runs of `nnda.filters.particle.smc` stays inside it);
its key covers the setting's data, the filter, its count and seed, and the
particle filters' options. The aggregate is ``summary.json``'s ``reentry``
(per setting: every filter's RMSE, ESS and scores, the paired
comparisons), the runtimes in ``timing.json``'s ``reentry``, and
``reentry_results.parquet`` (one row per job).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pyarrow as pa
from pydantic import Field

from nnda.files import path_component
from nnda.study.kinds.base import Job, JobKind, TablePlan, job_key, study_seed_only, study_table
from nnda.study.reentry import ReentrySetting, ReentryStudyConfig, filter_entries, run_filter, setting_results, source
from nnda.study.timing import split_timing

RESULTS_FILE = "reentry_results.parquet"

FIELDS = {"reentry": (ReentryStudyConfig | None, Field(default=None, description="the re-entry filter study"))}


@dataclass(frozen=True)
class ReentryJob:
    """One filter (``fi``-th of the setting's, ``n`` particles or None) on setting ``index``."""

    setting: ReentrySetting
    index: int
    fi: int
    name: str
    n: int | None
    config: ReentryStudyConfig


def plan(study, where: str) -> TablePlan:
    cfg = study_table(study, "reentry")
    names = [path_component(s.name, f"{where}: reentry setting name") for s in cfg.settings]
    if len(set(names)) != len(names):
        raise ValueError(f"{where}: reentry setting names {names} repeat one")
    options = {k: getattr(cfg, k) for k in ("runs", "resampling", "ess_threshold", "converted_kf_sigma_w",
                                            "chunk_particles", "seed")}
    jobs = []
    for index, setting in enumerate(cfg.settings):
        data = source(setting, cfg).digest(0)
        for fi, name, n in filter_entries(setting):
            label = name if n is None else f"{name}@{n}"
            key = job_key({"kind": "reentry", "data": data, "index": index, "fi": fi, "filter": name,
                           "particles": n, **options})
            spec = ReentryJob(setting, index, fi, name, n, cfg)
            jobs.append(Job("reentry", key, f"jobs/reentry/{setting.name}/{label}.json",
                            f"{label} on re-entry setting {setting.name}", spec))
    return TablePlan(cfg, tuple(jobs))


def run(job: ReentryJob) -> dict:
    return run_filter(job.setting, job.index, job.fi, job.name, job.n, job.config)


def results(cfg: ReentryStudyConfig, records: list[dict]) -> dict:
    """The study's results document (every setting, runtimes included) from its records in plan order."""
    settings = [setting_results(s, cfg, [r for r in records if r["setting"] == s.name]) for s in cfg.settings]
    return {"config": cfg.model_dump(mode="json"), "settings": settings,
            "runtime_s": sum(r["timing"]["runtime_s"] for r in records)}


def table(records: list[dict]) -> pa.Table:
    """One row per job: setting, filter, particles, time-averaged and final RMSE per component and position."""
    cols: dict[str, Any] = {"setting": pa.array([r["setting"] for r in records], pa.string()),
                            "filter": pa.array([r["entry"]["filter"] for r in records], pa.string()),
                            "particles": pa.array([r["entry"]["particles"] for r in records], pa.int64())}
    for part in ("time_avg", "final"):
        for c in records[0]["entry"][part]:
            cols[f"{part}_{c}"] = pa.array([r["entry"][part][c] for r in records], pa.float64())
    return pa.table(cols)


def aggregate(plan: TablePlan, records: list[dict]) -> tuple[dict, dict, dict]:
    kept, timing = split_timing(results(plan.config, records))
    return {"reentry": kept}, {"reentry": timing}, {RESULTS_FILE: table(records)}


KIND = JobKind(name="reentry", fields=FIELDS, work="[reentry]", given=lambda study: study.reentry is not None,
               plan=plan, run=run, aggregate=aggregate, check=study_seed_only("reentry"))
