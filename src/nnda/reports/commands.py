"""CLI commands that end in a report: ``nnda compare`` (run a study, then report), ``nnda report``,
``nnda plot-scenario``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from nnda.data.dataset import read_dataset
from nnda.errors import ConfigError, OutputError
from nnda.files import check_output_location
from nnda.study.config import load_study
from nnda.study.plan import JobSpec


def plot_scenario(
    dataset: Annotated[Path, typer.Argument(help="dataset directory")],
    out: Annotated[Path, typer.Option(help="PNG file to write")],
    overwrite: Annotated[bool, typer.Option(help="replace an existing file at --out")] = False,
) -> None:
    """Plot a dataset: coverage, clutter, target contacts and true tracks."""
    from nnda.reports.scenario_plot import plot_scenario as draw  # matplotlib only when plotting

    if out.is_dir():
        raise OutputError(f"--out {out}: is a directory; give the PNG file to write, e.g. {out / 'scenario.png'}")
    if out.suffix.lower() != ".png":
        raise ConfigError(f"--out {out}: unknown figure type {out.suffix or '(no suffix)'!r}; plot-scenario "
                          f"writes PNG: give a file name ending in .png")
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: already exists (pass --overwrite to replace it)")
    check_output_location(out, [dataset])
    draw(read_dataset(dataset), out)
    Console().print(f"wrote {out}", markup=False, highlight=False)


def report(
    study_dir: Annotated[Path, typer.Argument(help="study directory written by `nnda compare`")],
) -> None:
    """Rebuild report.md and report.html of a study directory from its saved results."""
    from nnda.reports.study_report import write_report  # matplotlib and plotly only when reporting

    Console().print(f"report: {write_report(study_dir)}")


def compare(
    study: Annotated[Path, typer.Option(help="study file (.toml or .json)")],
    out: Annotated[Path, typer.Option(help="study directory for job results, aggregates and the report")],
    resume: Annotated[bool, typer.Option(
        help="continue an interrupted study in --out, skipping finished jobs")] = False,
    dask: Annotated[str | None, typer.Option(
        help="run the jobs on Dask: a scheduler address, or 'local' for a LocalCluster (needs nnda[dask])")] = None,
    jobs: Annotated[int, typer.Option(
        min=1, help="local worker processes (1: in this process); Dask workers with --dask local")] = 2,
    overwrite: Annotated[bool, typer.Option(help="replace an earlier study directory at --out")] = False,
) -> None:
    """Run every tracker of a study on every run of every scenario, then write the report."""
    from nnda.reports.study_report import write_report  # matplotlib and plotly only when reporting
    from nnda.study.compare import compare as run_comparison  # scikit-learn and the trackers: only when run

    definition = load_study(study)
    console = Console()
    bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                   TextColumn("{task.fields[last]}"), TimeElapsedColumn(), TimeRemainingColumn(), console=console)
    task = bar.add_task(f"compare {definition.name}", total=None, last="")

    def on_job(done: int, total: int, job: JobSpec | None) -> None:
        if job is None:  # the study passed its checks: show the bar from here on
            bar.start()
        last = f"{job.scenario} run {job.run} {job.tracker}" if job is not None else ""
        bar.update(task, completed=done, total=total, last=last)

    try:
        result = run_comparison(definition, out, resume=resume, workers=jobs, dask=dask, on_job=on_job,
                                where=str(study), overwrite=overwrite)
    finally:
        bar.stop()
    ex = result.execution
    console.print(f"{ex.jobs_run} job(s) run, {ex.jobs_skipped} resumed, on {ex.executor} in {ex.seconds:.1f} s")
    console.print(f"report: {write_report(out)}")
