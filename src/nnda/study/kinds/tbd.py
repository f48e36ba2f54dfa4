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
the comparisons per setting) and its times in ``timing.json``'s ``tbd``.
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import Field

from nnda.data.frames import FramesConfig
from nnda.data.sources import config_digest
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

FIELDS = {"tbd": (TBDStudyConfig | None, Field(default=None, description="the track-before-detect study"))}


@dataclass(frozen=True)
class BlockJob:
    """One estimator on runs ``start``..``start + count - 1`` of setting ``index``; ``estimator`` None: the
    report's snapshot of run 0."""

    config: TBDStudyConfig
    index: int
    scene: FramesConfig
    start: int
    count: int
    estimator: str | None


def plan(study, where: str) -> TablePlan:
    cfg = study_table(study, "tbd")
    # what a record depends on beyond its scene and block (the scoring rules and the interval level do not enter)
    options = cfg.model_dump(mode="json", exclude={"ptcr_db", "scene", "runs", "exit_reentry", "confidence",
                                                   "chunk_runs", "acquisition", "steady_frames", "divergence_frames"})
    jobs = [Job("tbd", job_key({"kind": "tbd", "snapshot": True, **options, "scene": cfg.scene.model_dump(mode="json"),
                                "ptcr_db": cfg.ptcr_db[0]}),
                "jobs/tbd/snapshot.json", "TBD snapshot of run 0", BlockJob(cfg, 0, cfg.scene, 0, 1, None))]
    for index, (name, scene, runs) in enumerate(scenes(cfg)):
        for start in range(0, runs, cfg.chunk_runs):
            count = min(cfg.chunk_runs, runs - start)
            for estimator in estimators(cfg):
                key = job_key({"kind": "tbd", "data": config_digest(scene), "index": index, "start": start,
                               "count": count, "estimator": estimator, **options})
                jobs.append(Job("tbd", key, f"jobs/tbd/{name}/{estimator.replace(':', '-')}/runs-{start:04d}.json",
                                f"{estimator} on {name} runs {start}-{start + count - 1}",
                                BlockJob(cfg, index, scene, start, count, estimator)))
    return TablePlan(cfg, tuple(jobs))


def run(job: BlockJob) -> dict:
    if job.estimator is None:
        return {"snapshot": snapshot(job.config)}
    return {"index": job.index, "estimator": job.estimator, "start": job.start,
            **run_block(job.config, job.index, job.scene, job.start, job.count, job.estimator)}


def results(cfg: TBDStudyConfig, records: list[dict]) -> dict:
    """The study's results document (runtimes included) from its records in plan order."""
    settings, exit_reentry = [], None
    for index, (name, scene, runs) in enumerate(scenes(cfg)):
        blocks = {e: [r for r in records if r.get("index") == index and r.get("estimator") == e]
                  for e in estimators(cfg)}
        truth, got = assemble(cfg, scene, runs, blocks)
        if name == "exit-reentry":
            exit_reentry = exit_reentry_results(cfg, truth, got)
        else:
            settings.append(ptcr_results(cfg, scene, truth, got))
    runtime = sum(r["timing"]["seconds"] for r in records if "timing" in r)
    return study_results(cfg, settings, exit_reentry, runtime)


def aggregate(plan: TablePlan, records: list[dict]) -> tuple[dict, dict, dict]:
    kept, timing = split_timing(results(plan.config, records))
    snap = next(r["snapshot"] for r in records if "snapshot" in r)
    return {"tbd": kept}, {"tbd": timing}, {SNAPSHOT_FILE: snap}


KIND = JobKind(name="tbd", fields=FIELDS, work="[tbd]", given=lambda study: study.tbd is not None,
               plan=plan, run=run, aggregate=aggregate, check=study_seed_only("tbd"))
