"""Run a study's jobs: in this process, on local worker processes, or on a Dask cluster.

Layout of a study directory::

    study.json                         what was run (nnda.study manifest, with the fingerprint)
    jobs/...                           one file per finished job, written atomically (where: each kind's)
    summary.json, timing.json, *.parquet, ...  the aggregates (`nnda.study.results`)

Every job is independent (`nnda.study.kinds.base.Job`; a worker runs it
with its kind's ``run``) and its record is written as soon as it arrives,
by this process (so Dask workers need no shared disk for results), with
its key and the SHA-256 of its own content. With ``resume`` the jobs whose file exists
with the same key and an intact digest are kept and the others run, so a
study changed after a failure (the cause fixed) resumes with whatever still
holds; the aggregates are always rebuilt from the job files in plan order,
so a resumed study, a local one and a Dask one give the same bytes. A lock
(`nnda.files.directory_lock`) keeps a second writer off the directory.

Dask is optional (``pip install 'nnda[dask]'``) and imported only when asked
for. ``dask="local"`` starts a `LocalCluster` of ``workers`` single-threaded
processes; any other value is a scheduler address. Presets are generated on
the workers; model files and dataset directories must be readable there at
the same paths.
"""

from __future__ import annotations

import json
import multiprocessing
import shutil
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from nnda.errors import ConfigError, DatasetError
from nnda.files import digest, dumps, read_json, write_json
from nnda.study.kinds import KINDS
from nnda.study.kinds.base import Job
from nnda.study.plan import STUDY_FORMAT, STUDY_FORMAT_VERSION, StudyPlan

MANIFEST = "study.json"

#: progress: called with (number of jobs done, total, the job just finished or None at the start)
JobCallback = Callable[[int, int, Job | None], None]


@dataclass(frozen=True)
class Execution:
    """How the jobs ran: ``executor`` is "in-process", "local processes" or "dask <address>";
    ``workers`` the local worker count (a remote Dask cluster has its own)."""

    executor: str
    workers: int
    jobs_run: int
    jobs_skipped: int
    seconds: float


def check_out(out: Path, resume: bool, overwrite: bool) -> bool:
    """Whether ``out`` holds an earlier study; refuse an ``out`` that is a file, a directory holding
    something else, or an earlier study without ``resume`` (continue it) or ``overwrite`` (replace it)."""
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{out}: exists and is not a directory")
    if not out.exists() or not any(out.iterdir()):
        return False
    if resume and overwrite:
        raise ConfigError("give --resume or --overwrite, not both")
    if not (out / MANIFEST).is_file():
        raise DatasetError(f"{out}: not a study directory ({MANIFEST} is missing); choose another --out")
    if not (resume or overwrite):
        raise FileExistsError(f"{out}: already exists; pass --resume to continue that study, --overwrite to "
                              f"replace it, or choose another --out")
    read_json(out / MANIFEST, STUDY_FORMAT, STUDY_FORMAT_VERSION)  # a study manifest, of a version we read
    return True


#: every job record's format (each kind's fields inside); older versions are run again on resume and refused
#: by `read_job`, naming the version
JOB_FORMAT = "nnda.study-job"
JOB_FORMAT_VERSION = 5


def run_job(job: Job) -> dict:
    """Run one job with its kind's ``run`` (in any process): its record, with its format, version and key."""
    return {"format": JOB_FORMAT, "format_version": JOB_FORMAT_VERSION, **KINDS[job.kind].run(job.spec),
            "key": job.key}


def _sealed(record: dict) -> dict:
    """The record with the SHA-256 of its canonical content (without that field) in ``sha256``."""
    return {**record, "sha256": digest(dumps({k: v for k, v in record.items() if k != "sha256"}, None).encode())}


def _intact(record: dict) -> bool:
    return record.get("sha256") == _sealed(record)["sha256"]


def is_done(job: Job, out: Path) -> bool:
    """True when the job's file exists and holds a record with the job's key."""
    path = out / job.relpath
    if not path.is_file():
        return False
    try:
        record = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        return False  # cannot happen with atomic writes, but a damaged file is simply recomputed
    return (isinstance(record, dict) and record.get("format") == JOB_FORMAT
            and record.get("format_version") == JOB_FORMAT_VERSION and record.get("key") == job.key
            and _intact(record))  # an edited or damaged record is run again


def read_job(job: Job, out: Path) -> dict:
    """The saved record of a finished job; DatasetError if it is missing or of another job."""
    path = out / job.relpath
    record = read_json(path, JOB_FORMAT, JOB_FORMAT_VERSION)
    if record.get("key") != job.key:
        raise DatasetError(f"{path}: holds the result of another job definition (key differs)")
    if not _intact(record):
        raise DatasetError(f"{path}: corrupt or edited job file (its SHA-256 does not match its content); "
                           f"delete it and run the study again with --resume")
    return record


class JobFailed(RuntimeError):
    """A job raised: names the job; the jobs finished before it are kept for --resume."""

    def __init__(self, job: Job, exc: BaseException) -> None:
        super().__init__(f"job {job.relpath} ({job.title}) failed: "
                         f"{type(exc).__name__}: {exc}; finished jobs are kept: fix the cause, then run again "
                         f"with --resume (the jobs whose inputs did not change are kept)")


def _result(job: Job, future) -> dict:
    try:
        return future.result()
    except Exception as exc:
        raise JobFailed(job, exc) from exc


def _in_process(jobs: list[Job]) -> Iterator[tuple[Job, dict]]:
    for job in jobs:
        try:
            record = run_job(job)
        except Exception as exc:
            raise JobFailed(job, exc) from exc
        yield job, record


def _local_pool(jobs: list[Job], workers: int) -> Iterator[tuple[Job, dict]]:
    """Jobs on worker processes, yielded as they finish. After a failure no new job starts, the
    running ones finish (and are yielded, so they are kept), then the failure is raised."""
    # spawn: workers start clean (no copy of this process's threads, e.g. the progress bar's)
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))
    failure: JobFailed | None = None
    try:
        pending: dict[Future, Job] = {pool.submit(run_job, job): job for job in jobs}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                job = pending.pop(future)
                if future.cancelled():
                    continue
                try:
                    record = _result(job, future)
                except JobFailed as exc:
                    failure = failure or exc
                    for other in pending:
                        other.cancel()  # those not started yet; running ones cannot be cancelled
                    continue
                yield job, record
        if failure is not None:
            raise failure
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def require_dask():
    """The dask.distributed module; ConfigError naming the optional extra when it is not installed."""
    try:
        import dask.distributed
    except ImportError:
        raise ConfigError("--dask needs the optional extra nnda[dask]: pip install 'nnda[dask]'") from None
    return dask.distributed


@contextmanager
def dask_client(address: str, workers: int):
    """A dask.distributed Client: a LocalCluster of ``workers`` processes for "local", else ``address``."""
    distributed = require_dask()
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    if address == "local":
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            yield client
    else:
        try:
            client = Client(address, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise ConfigError(f"--dask {address}: cannot reach the Dask scheduler ({exc})") from None
        with client:
            yield client


def _dask(jobs: list[Job], address: str, workers: int) -> Iterator[tuple[Job, dict]]:
    as_completed = require_dask().as_completed
    with dask_client(address, workers) as client:
        futures = {client.submit(run_job, job, key=f"nnda-{job.key}", pure=False): job for job in jobs}
        try:
            for future in as_completed(futures):
                yield futures[future], _result(futures[future], future)
        finally:
            client.cancel(list(futures))


def run_jobs(plan: StudyPlan, out: str | Path, resume: bool = False, workers: int = 2, dask: str | None = None,
             on_job: JobCallback | None = None, overwrite: bool = False) -> Execution:
    """Run every job of ``plan`` not yet done in ``out``, writing each record as it arrives.

    ``workers`` = 1 without Dask runs the jobs in this process. The study
    manifest is written before the first job, so an interrupted study can be
    resumed. ``overwrite`` replaces an earlier study directory at ``out``
    (never a directory without a study manifest); `nnda.study.compare.compare`
    runs an overwriting study in a sibling directory, so the earlier one
    stays whole until the new one is done.
    """
    out = Path(out)
    if workers < 1:
        raise ConfigError(f"--jobs must be at least 1, got {workers}")
    if dask is not None:
        require_dask()  # before anything is written
    if check_out(out, resume, overwrite) and overwrite:
        shutil.rmtree(out)  # only ever a study directory: it holds study.json
    write_json(out / MANIFEST, plan.manifest())
    todo = [job for job in plan.jobs if not is_done(job, out)]
    skipped = len(plan.jobs) - len(todo)
    if dask is not None:
        stream, executor = _dask(todo, dask, workers), f"dask {dask}"
    elif workers == 1:
        stream, executor = _in_process(todo), "in-process"
    else:
        stream, executor = _local_pool(todo, workers), "local processes"
    start = time.perf_counter()
    done = skipped
    if on_job is not None:
        on_job(done, len(plan.jobs), None)
    if todo:
        for job, record in stream:
            write_json(out / job.relpath, _sealed(record), indent=None)
            done += 1
            if on_job is not None:
                on_job(done, len(plan.jobs), job)
    return Execution(executor, workers, len(todo), skipped, time.perf_counter() - start)
