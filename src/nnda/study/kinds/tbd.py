"""The ``tbd`` kind: track-before-detect particle filters, the matched-filter detector and the detect-then-track
chain on image frames (Bruno, Araújo & Pavlov; `nnda.study.tbd`). Its table holds
`nnda.study.tbd.TBDStudyConfig`'s fields but the seed and confidence, which are the study's::

    [tbd]
    runs = 100
    ptcr_db = [6.5, 8.1]
    chunk_runs = 25           # runs a job filters at once (bounds memory; results do not depend on it)

A job is one estimator (a filter, the detector, a chain tracker) on one
block of ``chunk_runs`` runs of one setting (a PTCR, or the exit and
re-entry scenario): frames are drawn per run, so blocks are independent and
a block's records are the same alone as among all. One more job keeps run 0's
frames and particles for the report's figure (``tbd_snapshot.json``). The
aggregate is ``summary.json``'s ``tbd`` (divergence, RMSE, detection and
the comparisons per setting), its times in ``timing.json``'s ``tbd``, and
``tbd_results.parquet`` (one row per PTCR and estimator).
"""

from __future__ import annotations

from dataclasses import dataclass

import pyarrow as pa
from pydantic import Field

from nnda.data.sources import FrameScenes
from nnda.study.kinds.base import Job, JobKind, TablePlan, job_key, study_seed_only, study_table
from nnda.study.tbd import TBDStudyConfig
from nnda.study.tbd_runs import (
    SNAPSHOT_FILE,
    assemble,
    estimators,
    exit_reentry_results,
    ptcr_results,
    run_block,
    scenes,
    snapshot,
    study_results,
)
from nnda.study.timing import split_timing

RESULTS_FILE = "tbd_results.parquet"

FIELDS = {"tbd": (TBDStudyConfig | None, Field(default=None, description="the track-before-detect study"))}


@dataclass(frozen=True)
class BlockJob:
    """One estimator on runs ``start``..``start + count - 1`` of setting ``index``; ``estimator`` None: the
    report's snapshot of run 0."""

    config: TBDStudyConfig
    index: int
    source: FrameScenes
    start: int
    count: int
    estimator: str | None


def plan(study, where: str) -> TablePlan:
    cfg = study_table(study, "tbd")
    # what a record depends on beyond its scene and block (the scoring rules and the interval level do not enter)
    options = cfg.model_dump(mode="json", exclude={"ptcr_db", "scene", "runs", "exit_reentry", "confidence",
                                                   "chunk_runs", "acquisition", "steady_frames", "divergence_frames"})
    first = scenes(cfg)[0][0]
    jobs = [Job("tbd", job_key({"kind": "tbd", "snapshot": True, "data": first.digest(0), **options}),
                "jobs/tbd/snapshot.json", "TBD snapshot of run 0", BlockJob(cfg, 0, first, 0, 1, None))]
    for index, (source, runs) in enumerate(scenes(cfg)):
        for start in range(0, runs, cfg.chunk_runs):
            count = min(cfg.chunk_runs, runs - start)
            for estimator in estimators(cfg):
                key = job_key({"kind": "tbd", "data": source.digest(start), "index": index, "start": start,
                               "count": count, "estimator": estimator, **options})
                jobs.append(Job("tbd", key, f"jobs/tbd/{source.name}/{estimator.replace(':', '-')}/"
                                            f"runs-{start:04d}.json",
                                f"{estimator} on {source.name} runs {start}-{start + count - 1}",
                                BlockJob(cfg, index, source, start, count, estimator)))
    return TablePlan(cfg, tuple(jobs))


def run(job: BlockJob) -> dict:
    if job.estimator is None:
        return {"snapshot": snapshot(job.config)}
    return {"index": job.index, "estimator": job.estimator, "start": job.start,
            **run_block(job.config, job.index, job.source, job.start, job.count, job.estimator)}


def results(cfg: TBDStudyConfig, records: list[dict]) -> dict:
    """The study's results document (runtimes included) from its records in plan order."""
    settings, exit_reentry = [], None
    for index, (source, runs) in enumerate(scenes(cfg)):
        blocks = {e: [r for r in records if r.get("index") == index and r.get("estimator") == e]
                  for e in estimators(cfg)}
        truth, got = assemble(cfg, source.config, runs, blocks)
        if source.name == "exit-reentry":
            exit_reentry = exit_reentry_results(cfg, truth, got)
        else:
            settings.append(ptcr_results(cfg, source.config, truth, got))
    runtime = sum(r["timing"]["seconds"] for r in records if "timing" in r)
    return study_results(cfg, settings, exit_reentry, runtime)


def table(doc: dict) -> pa.Table:
    """One row per (PTCR, filter or chain tracker): divergent runs of how many, the steady-state error (mean
    over the runs that did not diverge) and the share of present frames declared present."""
    rows = [(s["ptcr_db"], label, e) for s in doc["settings"] for label, e in (*s["filters"].items(),
                                                                               *s["chain"].items())]
    return pa.table({"ptcr_db": pa.array([r[0] for r in rows], pa.float64()),
                     "estimator": pa.array([r[1] for r in rows], pa.string()),
                     "divergent_runs": pa.array([r[2]["divergence"]["count"] for r in rows], pa.int64()),
                     "runs": pa.array([r[2]["divergence"]["runs"] for r in rows], pa.int64()),
                     "steady_error_px": pa.array([r[2]["steady_error"]["mean"] for r in rows], pa.float64()),
                     "declared_present": pa.array([r[2]["declared_present"] for r in rows], pa.float64())})


def aggregate(plan: TablePlan, records: list[dict]) -> tuple[dict, dict, dict]:
    kept, timing = split_timing(results(plan.config, records))
    snap = next(r["snapshot"] for r in records if "snapshot" in r)
    return {"tbd": kept}, {"tbd": timing}, {SNAPSHOT_FILE: snap, RESULTS_FILE: table(kept)}


KIND = JobKind(name="tbd", fields=FIELDS, work="[tbd]", given=lambda study: study.tbd is not None,
               plan=plan, run=run, aggregate=aggregate, check=study_seed_only("tbd"))
