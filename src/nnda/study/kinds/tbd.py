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

from nnda.data.frames import frames_bytes
from nnda.data.sources import FrameScenes
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
from nnda.study.tbd import TBDStudyConfig
from nnda.study.tbd_runs import (
    SNAPSHOT_FILE,
    SNAPSHOT_FRAMES,
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


#: bytes per aspect and extended-grid position of each run of a block that the matched-filter detector holds
#: while it works on a frame (its log-likelihood ratios and energy tables)
ASPECT_BYTES = 24
#: bytes per particle of each run of a block (the state, 5 float64, and its copies: proposal, resampled,
#: weights, the likelihood's temporaries; measured 260-320 B)
PARTICLE_BYTES = 320
#: bytes per pixel of each frame the report's snapshot keeps as JSON numbers
SNAPSHOT_PIXEL_BYTES = 56
#: bytes per run, frame and value of the records the aggregation reads (a Python float, then an array entry)
AGGREGATE_BYTES = 40


def memory_parts(cfg: TBDStudyConfig) -> list[MemoryPart]:
    """The study's memory estimate: each setting's block job (a block of ``chunk_runs`` runs: its frames
    (`nnda.data.frames.frames_bytes`), the detector's work on a frame, the particles of the largest filter), the
    snapshot job and the aggregation (every run's truth and every estimator's estimates, the snapshot's frames)."""
    n = max(f.particles for f in cfg.filters)
    chain = len(cfg.chain.trackers) if cfg.chain is not None else 0
    values = 5 + 4 * len(cfg.filters) + 3 * chain  # truth, each filter's and each chain tracker's per run and frame
    parts, records = [], 0
    settings = scenes(cfg)
    for source, runs in settings:
        scene = source.config
        L, M, K, h = scene.rows, scene.cols, scene.frames, scene.template_half
        c = min(cfg.chunk_runs, runs)
        frames = frames_bytes(scene, c)
        work = c * (len(scene.aspects) * (L + 2 * h) * (M + 2 * h) * ASPECT_BYTES + n * PARTICLE_BYTES)
        k = "exit_reentry.frames" if source.name == "exit-reentry" else "scene.frames"
        parts.append(MemoryPart(
            f"a job on {source.name}", f"a block of {c:,} runs (chunk_runs = {cfg.chunk_runs:,}) of {K:,} frames "
            f"({k}) of {L:,} x {M:,} pixels (scene.rows x scene.cols): {human_bytes(frames)}; the detector's and "
            f"{n:,} particles' work: {human_bytes(work)}",
            f"scene.rows, scene.cols, {k} or chunk_runs" if frames >= work else "chunk_runs or particles",
            frames + work))
        records += runs * K * values * AGGREGATE_BYTES
    scene = settings[0][0].config
    shown = len(SNAPSHOT_FRAMES) + 1
    images = shown * scene.rows * scene.cols * SNAPSHOT_PIXEL_BYTES
    parts.append(MemoryPart("the snapshot of run 0", f"{scene.rows:,} x {scene.cols:,} pixels x {scene.frames:,} "
                            f"frames", "scene.rows or scene.cols",
                            frames_bytes(scene, 1) + images + cfg.filters[0].particles * PARTICLE_BYTES))
    runs = ", ".join(f"{source.name}: {runs:,} runs x {source.config.frames:,} frames" for source, runs in settings)
    parts.append(MemoryPart("the aggregation", f"{runs}; {values} values per run and frame, the snapshot's {shown} "
                            f"frames", "runs or scene.frames", records + images))
    return parts


def plan(study, where: str) -> TablePlan:
    cfg = study_table(study, "tbd")
    check_memory(where, "tbd", memory_parts(cfg), cfg.max_memory_gib, "tbd")
    # what a record depends on beyond its scene and block (the scoring rules and the interval level do not enter)
    options = cfg.model_dump(mode="json", exclude={"ptcr_db", "scene", "runs", "exit_reentry", "confidence",
                                                   "chunk_runs", "acquisition", "steady_frames", "divergence_frames",
                                                   MEMORY_FIELD})
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
