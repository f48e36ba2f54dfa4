"""A whole comparison: check the study, run its jobs, aggregate, evaluate the models.

The report is the next stage's (`nnda.reports.study_report.write_report`, which reads what
this stage wrote); the ``nnda compare`` command runs both.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from nnda.files import atomic_directory, check_output_path, directory_lock, write_json
from nnda.models.ablation import ABLATION_FILE
from nnda.study.classifier import CLASSIFIER_FILE, evaluate_models, read_ablation
from nnda.study.config import Study
from nnda.study.plan import StudyPlan, plan_study
from nnda.study.results import write_results
from nnda.study.runner import Execution, JobCallback, check_out, run_jobs


@dataclass(frozen=True)
class Comparison:
    """What `compare` did: the plan, how its jobs ran, and the summary."""

    plan: StudyPlan
    execution: Execution
    summary: dict


def compare(study: Study, out: str | Path, resume: bool = False, workers: int = 2, dask: str | None = None,
            on_job: JobCallback | None = None, where: str = "study", overwrite: bool = False) -> Comparison:
    """Run ``study`` into directory ``out`` (see `nnda.study.runner` for its layout).

    Every input is checked before the first job, and ``out`` may not be,
    contain or lie inside one; with ``resume`` the jobs already in ``out``
    are kept, with ``overwrite`` an earlier study there is replaced once the
    new one is complete (it runs in a sibling directory; a failure or an
    interruption leaves the earlier study whole). A second ``compare`` on the
    same ``out`` is refused while one runs. ``where`` names the study in
    error messages.
    """
    out = Path(out)
    check_output_path(out, study.inputs(), "--out")
    plan = plan_study(study, where)
    ablation = read_ablation(study.ablation) if study.ablation is not None else None

    def run(into: Path) -> Comparison:
        execution = run_jobs(plan, into, resume=resume, workers=workers, dask=dask, on_job=on_job)
        summary = write_results(plan, into, execution)
        write_json(into / CLASSIFIER_FILE, evaluate_models(plan.models))
        if ablation is not None:
            write_json(into / ABLATION_FILE, ablation)
        else:
            (into / ABLATION_FILE).unlink(missing_ok=True)  # a resumed study keeps no stale copy
        return Comparison(plan, execution, summary)

    with directory_lock(out):
        if check_out(out, resume, overwrite) and overwrite:
            with atomic_directory(out, overwrite=True) as fresh:
                return run(fresh)
        return run(out)
