"""A finished study's aggregates, rebuilt from its job records, and the checksums of everything written.

`write_results` reads every job record of the plan (each checked against
its key and its own SHA-256), hands each kind its records in plan order
(`nnda.study.kinds.base.JobKind.aggregate`) and writes:

* ``summary.json``: the study (name, fingerprint, seed, confidence) and
  each kind's entries (the ``track`` kind's ``trackers`` and ``scenarios``,
  the ``filter`` kind's ``filters``, ...): deterministic, no wall-clock time;
* ``timing.json``: how the study was executed, on which machine, and each
  kind's time per scan or step;
* each kind's files: Parquet tables and JSON documents (a kind returns None
  for a file it may write but does not this time: a stale copy goes);
* ``checksums.json``: the SHA-256 of every file above
  (`nnda.study.checksums`), against which every reader checks a file before
  it reads it (`nnda report` among them).

Everything but ``timing.json`` and ``timing.*`` tables is the same, byte
for byte, for the same study and seed, run at once, resumed, locally or
on Dask.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from nnda.errors import DatasetError
from nnda.files import atomic_file, read_json, write_json
from nnda.study.checksums import read_checked, write_checksums
from nnda.study.kinds import KINDS
from nnda.study.plan import StudyPlan
from nnda.study.runner import Execution, read_job
from nnda.version import __version__

SUMMARY_FORMAT = "nnda.study-summary"
TIMING_FORMAT = "nnda.study-timing"
FORMAT_VERSION = 1
SUMMARY_FILE = "summary.json"
TIMING_SUMMARY_FILE = "timing.json"


def _write_parquet(table: pa.Table, path: Path) -> None:
    with atomic_file(path) as tmp:
        pq.write_table(table, tmp)


def _machine() -> dict:
    return {"python": platform.python_version(), "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "nnda_version": __version__}


def write_results(plan: StudyPlan, out: str | Path, execution: Execution) -> dict:
    """Aggregate every job of ``out`` into the files of the module docstring; returns the summary."""
    out = Path(out)
    records = {name: [] for name in plan.kinds}
    for job in plan.jobs:
        records[job.kind].append(read_job(job, out))
    study = plan.study
    summary = {"format": SUMMARY_FORMAT, "format_version": FORMAT_VERSION, "study": study.name,
               "fingerprint": plan.fingerprint, "seed": study.seed, "confidence": study.confidence}
    timing = {"format": TIMING_FORMAT, "format_version": FORMAT_VERSION, "fingerprint": plan.fingerprint,
              "execution": {"executor": execution.executor, "workers": execution.workers,
                            "jobs_run": execution.jobs_run, "jobs_skipped": execution.jobs_skipped,
                            "seconds": execution.seconds},
              "machine": _machine()}
    files: dict[str, pa.Table | dict | None] = {}
    for name, part in plan.kinds.items():
        try:
            summary_part, timing_part, kind_files = KINDS[name].aggregate(part, records[name])
        except DatasetError as exc:
            raise DatasetError(f"{out}: {exc}") from None
        summary.update(summary_part)
        timing.update(timing_part)
        files.update(kind_files)
    written = []
    for file, content in files.items():
        if content is None:
            (out / file).unlink(missing_ok=True)
        elif isinstance(content, pa.Table):
            _write_parquet(content, out / file)
            written.append(file)
        else:
            write_json(out / file, content)
            written.append(file)
    write_json(out / SUMMARY_FILE, summary)
    write_json(out / TIMING_SUMMARY_FILE, timing)
    written += [SUMMARY_FILE, TIMING_SUMMARY_FILE]
    write_checksums(out, written, plan.fingerprint)
    return summary


def read_summary(out: str | Path) -> tuple[dict, dict]:
    """The checked ``summary.json`` and ``timing.json`` of a study directory, with every per-tracker mapping
    back in the study's tracker order (the files sort their keys)."""
    summary = read_json(read_checked(out, SUMMARY_FILE), SUMMARY_FORMAT, FORMAT_VERSION)
    timing = read_json(read_checked(out, TIMING_SUMMARY_FILE), TIMING_FORMAT, FORMAT_VERSION)
    order = [t["label"] for t in summary.get("trackers", [])]
    for sc in summary.get("scenarios", []) + timing.get("scenarios", []):
        sc["trackers"] = {label: sc["trackers"][label] for label in order}
    return summary, timing
