"""Run a whole study: check it, run its jobs, aggregate.

The report is the next stage's (`nnda.reports.study_report.write_report`,
which reads what this stage wrote); ``nnda compare`` (alias ``nnda run``)
runs both.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from nnda.files import atomic_output, check_output_path, directory_lock, sweep_stale_within
from nnda.study.plan import StudyPlan, plan_study
from nnda.study.results import write_results
from nnda.study.runner import Execution, JobCallback, check_out, run_jobs


@dataclass(frozen=True)
class Comparison:
    """What `compare` did: the plan, how its jobs ran, and the summary."""

    plan: StudyPlan
    execution: Execution
    summary: dict


def compare(study, out: str | Path, resume: bool = False, workers: int = 2, dask: str | None = None,
            on_job: JobCallback | None = None, where: str = "study", overwrite: bool = False) -> Comparison:
    """Run ``study`` (a `nnda.study.config.Study`) into directory ``out`` (see `nnda.study.runner` for its
    layout).

    Every input is checked before the first job, and ``out`` may not be,
    contain or lie inside one; with ``resume`` the jobs already in ``out``
    are kept, with ``overwrite`` an earlier study there is replaced once the
    new one is complete (it runs in a sibling directory; a failure or an
    interruption leaves the earlier study whole). A second ``compare`` on the
    same ``out`` is refused while one runs; the temporary files a stopped
    ``compare`` left in and beside ``out`` are removed first. ``where`` names
    the study in error messages.
    """
    out = Path(out)
    check_output_path(out, study.inputs(), "--out")
    plan = plan_study(study, where)

    def run(into: Path) -> Comparison:
        execution = run_jobs(plan, into, resume=resume, workers=workers, dask=dask, on_job=on_job)
        return Comparison(plan, execution, write_results(plan, into, execution))

    with directory_lock(out):  # taking it removes what stopped writers left beside out
        if out.is_dir():  # and inside it: their temporaries (never a finished job's record, kept for --resume)
            sweep_stale_within(out)
        if check_out(out, resume, overwrite) and overwrite:
            with atomic_output(out, overwrite=True, locked=True) as fresh:
                return run(fresh)
        return run(out)
