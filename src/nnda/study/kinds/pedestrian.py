"""The ``pedestrian`` kind: PHD filters and motion models on simulated walkers (Frencl 2014, Tests 1-4;
`nnda.study.pedestrian`). Its table holds `nnda.study.pedestrian.PedestrianStudyConfig`'s fields but the seed
and confidence, which are the study's::

    [pedestrian]
    tests = ["test1", "test2", "test3", "test4"]
    runs = 300                # accuracy runs of Tests 2-3
    test4_runs = 600
    stress_runs = 25
    block_runs = 25           # runs one job filters (the results do not depend on it)

A job is one filter on one block of runs of one walker scene, each run
scored in the job; a filter on the same runs of the same scene in two
tests (GM-PHD and EK-PHD on the stress scene, in Test 2 and beyond it) is
one job. Test 1 (the heading profiles' draws) is one job. The aggregate is
``summary.json``'s ``pedestrian`` (the tests' accuracy and stress tables,
the differences with their intervals, Test 1, the comparison beyond the
thesis), its times in ``timing.json``'s ``pedestrian``, and
``pedestrian_results.parquet`` (one row per scene, filter and run).
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass

import pyarrow as pa
from pydantic import Field

from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.sources import resolve_scenes
from nnda.study.kinds.base import (
    Job,
    JobKind,
    MemoryPart,
    TablePlan,
    check_memory,
    job_key,
    study_seed_only,
    study_table,
)
from nnda.study.pedestrian import FilterSpec, PedestrianStudyConfig, groups, run_block, study_results
from nnda.study.pedestrian_scores import run_test1
from nnda.study.timing import split_timing

RESULTS_FILE = "pedestrian_results.parquet"

FIELDS = {"pedestrian": (PedestrianStudyConfig | None, Field(default=None, description="the pedestrian study"))}


@dataclass(frozen=True)
class BlockJob:
    """Filter ``f`` on runs ``first``..``first + count - 1`` of walker scene ``scene``; ``f`` None: Test 1."""

    scene: str
    f: FilterSpec | None
    first: int
    count: int
    keep_estimates: bool
    config: PedestrianStudyConfig


def _slug(label: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", label.lower()).strip("-")


#: bytes per run and scan of a filter's record in the aggregation (its per-scan sums, counts and weights as
#: Python numbers; measured 320 B), and more for a run that keeps its estimates (Test 4's density map)
RECORD_BYTES, ESTIMATE_BYTES = 400, 200
#: bytes per bootstrap resample, run and scan of an accuracy table's paired bootstrap (the resampled per-scan
#: sums of one filter at a time; measured 16 B)
BOOTSTRAP_BYTES = 16


def memory_parts(cfg: PedestrianStudyConfig) -> list[MemoryPart]:
    """The study's memory estimate: the aggregation holds every filter's run records (runs x scans of its walker
    scene) and, for an accuracy table, its paired bootstrap (``bootstrap`` resamples x runs x scans). A job
    filters one run at a time of a shipped walker scene: its size is the scene's, bounded by the trackers'."""
    records, boot, sizes = 0, 0, []
    for g in groups(cfg):
        S = PEDESTRIAN_SCENES[g.scene].n_scans
        records += len(g.filters) * g.runs * S * (RECORD_BYTES + (ESTIMATE_BYTES if g.keeps_estimates else 0))
        if g.role == "accuracy":
            boot = max(boot, cfg.bootstrap * g.runs * S * BOOTSTRAP_BYTES)
        sizes.append(f"{g.scene}: {g.runs:,} runs x {S} scans x {len(g.filters)} filters")
    return [MemoryPart("the aggregation", f"{'; '.join(sizes)}; bootstrap = {cfg.bootstrap:,} resamples",
                       "runs, test4_runs, stress_runs or bootstrap", records + boot)]


def plan(study, where: str) -> TablePlan:
    cfg = study_table(study, "pedestrian")
    check_memory(where, "pedestrian", memory_parts(cfg), cfg.max_memory_gib, "pedestrian")
    common = {"kind": "pedestrian", "seed": cfg.seed, "birth": cfg.birth, "cutoff_m": cfg.cutoff_m}
    jobs: dict[str, Job] = {}
    if "test1" in cfg.tests:
        key = job_key({**common, "test1": True})
        jobs[key] = Job("pedestrian", key, "jobs/pedestrian/test1.json", "pedestrian Test 1 (heading profiles)",
                        BlockJob("", None, 0, 0, False, cfg))
    # (scene, filter label) -> the filter, the most runs a test asks of it there, whether they keep estimates
    runs: dict[tuple[str, str], tuple[FilterSpec, int, bool]] = {}
    for g in groups(cfg):
        for f in g.filters:
            _, most, keep = runs.get((g.scene, f.label), (f, 0, False))
            runs[g.scene, f.label] = (f, max(most, g.runs), keep or g.keeps_estimates)
    for (scene, _), (f, count, keep) in runs.items():
        (source,) = resolve_scenes(preset=scene)
        data = source.digest(0)
        for first in range(0, count, cfg.block_runs):
            n = min(cfg.block_runs, count - first)
            key = job_key({**common, "data": data, "filter": asdict(f), "first": first, "count": n, "estimates": keep})
            jobs[key] = Job("pedestrian", key, f"jobs/pedestrian/{scene}/{_slug(f.label)}/runs-{first:04d}.json",
                            f"{f.label} on {scene} runs {first}-{first + n - 1}",
                            BlockJob(scene, f, first, n, keep, cfg))
    return TablePlan(cfg, tuple(jobs.values()))


def run(job: BlockJob) -> dict:
    cfg = job.config
    if job.f is None:
        return {"test1": run_test1(cfg.seed, cfg.confidence)}
    return {"scene": job.scene, "label": job.f.label, "first": job.first,
            "runs": run_block(job.scene, job.f, job.first, job.count, cfg.seed, cfg.birth, cfg.cutoff_m,
                              job.keep_estimates)}


def table(runs: dict[tuple[str, str], list[dict]]) -> pa.Table:
    """One row per (walker scene, filter, run): the run's measures (`nnda.study.pedestrian_scores.score_run`)."""
    rows = [(scene, label, i, r["measures"]) for (scene, label), rs in runs.items() for i, r in enumerate(rs)]
    keys = list(rows[0][3]) if rows else []
    return pa.table({"scene": pa.array([r[0] for r in rows], pa.string()),
                     "filter": pa.array([r[1] for r in rows], pa.string()),
                     "run": pa.array([r[2] for r in rows], pa.int32()),
                     **{k: pa.array([r[3][k] for r in rows], pa.int64() if k == "duplicates" else pa.float64())
                        for k in keys}})


def aggregate(plan: TablePlan, records: list[dict]) -> tuple[dict, dict, dict]:
    runs: dict[tuple[str, str], list[dict]] = {}
    for r in sorted((r for r in records if "runs" in r), key=lambda r: (r["scene"], r["label"], r["first"])):
        runs.setdefault((r["scene"], r["label"]), []).extend(r["runs"])
    test1 = next((r["test1"] for r in records if "test1" in r), None)
    kept, timing = split_timing(study_results(plan.config, runs, test1))
    return {"pedestrian": kept}, {"pedestrian": timing}, {RESULTS_FILE: table(runs)}


KIND = JobKind(name="pedestrian", fields=FIELDS, work="[pedestrian]",
               given=lambda study: study.pedestrian is not None, plan=plan, run=run, aggregate=aggregate,
               check=study_seed_only("pedestrian"))
