"""A whole job kind in one module: a scalar Kalman filter against the raw measurements on a random walk.

The smallest worked example of a study kind (docs/extending/study-kind.md): a study-file table, jobs over blocks of
runs, a record per job, an aggregate with intervals from `nnda.study.stats`, a Parquet table. Registering
it is one line, ``KINDS[KIND.name] = KIND`` (in nnda: one entry of the tuple in `nnda.study.kinds`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa
from pydantic import BaseModel, Field

from nnda.study.kinds.base import STRICT, Job, JobKind, job_key
from nnda.study.stats import mean_ci, root_mean_square


class RandomWalk(BaseModel):
    """The ``[random_walk]`` table: ``runs`` of ``steps`` steps, process and measurement variances, runs per job."""

    model_config = STRICT

    runs: int = Field(20, ge=2)
    steps: int = Field(50, ge=2)
    q: float = Field(1.0, gt=0)
    r: float = Field(4.0, gt=0)
    block_runs: int = Field(10, ge=1)


@dataclass(frozen=True)
class Block:
    """Runs ``first``..``first + count - 1`` of the table, drawn with ``seed``."""

    table: RandomWalk
    first: int
    count: int
    seed: int


@dataclass(frozen=True)
class Plan:
    table: RandomWalk
    confidence: float
    jobs: tuple[Job, ...]

    def manifest(self) -> dict:
        return {}


def plan(study, where: str) -> Plan:
    t = study.random_walk
    jobs = tuple(Job("random_walk", job_key({"kind": "random_walk", **t.model_dump(), "first": first,
                                             "seed": study.seed}),
                     f"jobs/random_walk/runs-{first:04d}.json", f"random walk runs {first}-",
                     Block(t, first, min(t.block_runs, t.runs - first), study.seed))
                 for first in range(0, t.runs, t.block_runs))
    return Plan(t, study.confidence, jobs)


def run(block: Block) -> dict:
    """Each run of the block drawn from (seed, run): truth, measurements, the filter; per-run RMSE of both."""
    t, kalman, raw = block.table, [], []
    for run_index in range(block.first, block.first + block.count):
        rng = np.random.default_rng([block.seed, run_index])
        x = np.cumsum(rng.normal(0.0, np.sqrt(t.q), t.steps))
        z = x + rng.normal(0.0, np.sqrt(t.r), t.steps)
        est, p, out = z[0], t.r, np.empty(t.steps)
        for k in range(t.steps):
            if k:
                p += t.q
                gain = p / (p + t.r)
                est, p = est + gain * (z[k] - est), (1 - gain) * p
            out[k] = est
        kalman.append(float(root_mean_square((out - x) ** 2)))
        raw.append(float(root_mean_square((z - x) ** 2)))
    return {"first": block.first, "kalman_rmse": kalman, "raw_rmse": raw}


def aggregate(plan: Plan, records: list[dict]) -> tuple[dict, dict, dict]:
    records = sorted(records, key=lambda r: r["first"])
    kalman = np.concatenate([r["kalman_rmse"] for r in records])
    raw = np.concatenate([r["raw_rmse"] for r in records])
    summary = {"kalman_rmse": mean_ci(kalman, plan.confidence, low=0.0),
               "raw_rmse": mean_ci(raw, plan.confidence, low=0.0),
               "difference": mean_ci(kalman - raw, plan.confidence)}
    table = pa.table({"run": pa.array(np.arange(kalman.size), pa.int32()), "kalman_rmse": kalman, "raw_rmse": raw})
    return {"random_walk": summary}, {}, {"random_walk.parquet": table}


KIND = JobKind(name="random_walk", fields={"random_walk": (RandomWalk | None, None)}, work="[random_walk]",
               given=lambda study: study.random_walk is not None, plan=plan, run=run, aggregate=aggregate)
