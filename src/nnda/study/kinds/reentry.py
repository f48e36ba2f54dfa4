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

from nnda.data.reentry import simulate_bytes
from nnda.files import path_component
from nnda.study.kinds.base import (
    MEMORY_FIELD,
    Job,
    JobKind,
    MemoryPart,
    TablePlan,
    check_memory,
    human_bytes,
    job_key,
    study_seed_only,
    study_table,
)
from nnda.study.reentry import (
    BOOTSTRAP_RESAMPLES,
    PARTICLE_FILTERS,
    ReentrySetting,
    ReentryStudyConfig,
    filter_entries,
    run_filter,
    setting_results,
    source,
)
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


#: bytes per run and step of a job beside its data: the estimates, errors and ESS, and the record's lists (a
#: Python float per run and step, then its JSON text)
RECORD_BYTES = 200
#: bytes per particle of the chunk a particle filter holds at once (the state, 4 float64, and its copies:
#: proposal, resampled, weights, the transition's temporaries; resample-move needs the most, about 250 B)
PARTICLE_BYTES = 256
#: bytes per run and step of each filter's record in the aggregation (the Python floats of its squared
#: position errors, then their array)
AGGREGATE_BYTES = 48


def memory_parts(cfg: ReentryStudyConfig) -> list[MemoryPart]:
    """The study's memory estimate: the largest job (one filter on every run of a setting: the runs' data, its
    record and the particle chunk) and the aggregation (every filter's records, and the paired bootstrap of an
    RMSE ratio, `BOOTSTRAP_RESAMPLES` resamples x runs x steps)."""
    R, K = cfg.runs, cfg.steps
    runs = f"runs = {R:,} x steps = {K:,}"
    counts = sorted({n for s in cfg.settings if set(s.filters) & set(PARTICLE_FILTERS) for n in s.particles})
    chunk = max((min(R, max(1, cfg.chunk_particles // n)) * n for n in counts), default=0)
    data = simulate_bytes(source(cfg.settings[0], cfg).config, R) + R * K * RECORD_BYTES
    particles = chunk * PARTICLE_BYTES
    labels = sum(len(filter_entries(s)) for s in cfg.settings)
    return [
        MemoryPart("a job", f"{runs}: {human_bytes(data)} of runs; {chunk:,} particles at once (chunk_particles = "
                            f"{cfg.chunk_particles:,}, or one run's, of particles {counts}): {human_bytes(particles)}",
                   "runs or steps" if data >= particles else "chunk_particles or particles", data + particles),
        MemoryPart("the aggregation", f"{runs}, {labels} filter runs, {BOOTSTRAP_RESAMPLES:,} bootstrap resamples",
                   "runs or steps", R * K * (labels * AGGREGATE_BYTES + BOOTSTRAP_RESAMPLES * 8)),
    ]


def plan(study, where: str) -> TablePlan:
    cfg = study_table(study, "reentry")
    check_memory(where, "reentry", memory_parts(cfg), cfg.max_memory_gib, "reentry")
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
    return {"config": cfg.model_dump(mode="json", exclude={MEMORY_FIELD}), "settings": settings,
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
