"""CLI commands that run a study or draw from one: ``nnda compare`` (run a study, then report), ``nnda report``,
``nnda plot-scenario``, ``nnda reentry``, ``nnda tbd`` and ``nnda pedestrian``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from nnda.data.dataset import read_dataset
from nnda.errors import ConfigError, OutputError, validated
from nnda.files import check_output_location, read_config, refuse_existing, write_json, write_results_directory
from nnda.reports.pages import REPORT_HTML
from nnda.reports.pedestrian_section import write_report as write_pedestrian_report
from nnda.reports.reentry_section import write_report as write_reentry_report
from nnda.reports.tbd_section import frames_figure
from nnda.reports.tbd_section import write_report as write_tbd_report
from nnda.study.config import load_study
from nnda.study.kinds.base import Job
from nnda.study.pedestrian import RESULTS_FILE as PEDESTRIAN_RESULTS
from nnda.study.pedestrian import TESTS, PedestrianStudyConfig, run_pedestrian_study, split_timing
from nnda.study.pedestrian import TIMING_FILE as PEDESTRIAN_TIMING
from nnda.study.reentry import RESULTS_FILE as REENTRY_RESULTS
from nnda.study.reentry import ReentryStudyConfig, run_reentry_study
from nnda.study.tbd import RESULTS_FILE as TBD_RESULTS
from nnda.study.tbd import TBDStudyConfig, run_tbd_study


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

    def on_job(done: int, total: int, job: Job | None) -> None:
        if job is None:  # the study passed its checks: show the bar from here on
            bar.start()
        last = job.title if job is not None else ""
        bar.update(task, completed=done, total=total, last=last)

    try:
        result = run_comparison(definition, out, resume=resume, workers=jobs, dask=dask, on_job=on_job,
                                where=str(study), overwrite=overwrite)
    finally:
        bar.stop()
    ex = result.execution
    console.print(f"{ex.jobs_run} job(s) run, {ex.jobs_skipped} resumed, on {ex.executor} in {ex.seconds:.1f} s")
    console.print(f"report: {write_report(out)}")


def reentry(
    out: Annotated[Path, typer.Option(help="directory for results.json, report.md and report.html")],
    config: Annotated[Path | None, typer.Option(help="study config (.toml or .json; default: the paper's "
                                                     "setting, the particle sweep and the precise sensor)")] = None,
    runs: Annotated[int | None, typer.Option(min=1, help="Monte Carlo runs (overrides the config)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed (overrides the config)")] = None,
    overwrite: Annotated[bool, typer.Option(help="replace an earlier directory at --out")] = False,
) -> None:
    """Run the seed-004 ballistic re-entry filter study (every filter on the same runs) and write its report."""
    data = read_config(config, "re-entry study") if config is not None else {}
    data |= {k: v for k, v in (("runs", runs), ("seed", seed)) if v is not None}
    cfg = validated(ReentryStudyConfig, data, str(config or "--runs/--seed"), "re-entry study")
    refuse_existing(out, overwrite)
    results = run_reentry_study(cfg)
    write_results_directory(out, overwrite, REENTRY_RESULTS, results, write_reentry_report)
    Console().print(f"re-entry study: {results['runtime_s']:.0f} s; report: {out / REPORT_HTML}")


def tbd(
    out: Annotated[Path, typer.Option(help="directory for results.json, report.md and report.html")],
    config: Annotated[Path | None, typer.Option(help="study config (.toml or .json; default: 100 runs x 20 "
                                                     "frames at 6.5 and 8.1 dB, APF 5,000, RS 8,000, ...)")] = None,
    runs: Annotated[int | None, typer.Option(min=1, help="Monte Carlo runs (overrides the config)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed (overrides the config)")] = None,
    overwrite: Annotated[bool, typer.Option(help="replace an earlier directory at --out")] = False,
    chain: Annotated[bool, typer.Option(help="also track the detector's detections with GNN and MHT (the "
                                             "config's `chain`; --no-chain: the detector alone)")] = True,
) -> None:
    """Run the seed-003 track-before-detect study (every filter on the same frames) and write its report."""
    data = read_config(config, "tbd study") if config is not None else {}
    data |= {k: v for k, v in (("runs", runs), ("seed", seed)) if v is not None}
    if not chain:
        data["chain"] = None
    cfg = validated(TBDStudyConfig, data, str(config or "--runs/--seed"), "tbd study")
    refuse_existing(out, overwrite)
    results = run_tbd_study(cfg)
    figure = frames_figure(cfg)
    write_results_directory(out, overwrite, TBD_RESULTS, results, lambda d, r: write_tbd_report(d, r, figure))
    Console().print(f"tbd study: {results['runtime_s']:.0f} s; report: {out / REPORT_HTML}")


def pedestrian(
    out: Annotated[Path, typer.Option(help="directory for results.json, report.md, report.html and figures/")],
    tests: Annotated[list[str] | None, typer.Argument(help="test1, test2, test3, test4 (default: all)")] = None,
    config: Annotated[Path | None, typer.Option(help="study config (.toml or .json; fields of "
                                                     "nnda.study.pedestrian.PedestrianStudyConfig)")] = None,
    runs: Annotated[int | None, typer.Option(min=2, help="accuracy runs of Tests 2-3 (default 300)")] = None,
    test4_runs: Annotated[int | None, typer.Option(min=2, help="runs of Test 4 (default 600)")] = None,
    stress_runs: Annotated[int | None, typer.Option(min=2, help="runs of the stress scenes (default 25)")] = None,
    birth: Annotated[str | None, typer.Option(help="measurement (default) or oracle (the thesis's)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed (overrides the config)")] = None,
    jobs: Annotated[int | None, typer.Option(min=1, help="worker processes")] = None,
    beyond: Annotated[bool | None, typer.Option(help="also GNN, JPDA, MHT and CPHD on the stress scene")] = None,
    overwrite: Annotated[bool, typer.Option(help="replace an earlier directory at --out")] = False,
) -> None:
    """Run seed-000's pedestrian study (Tests 2-4: PHD filters and motion models on walkers) and write its report."""
    unknown = [t for t in tests or () if t not in (*TESTS, "all")]
    if unknown:
        raise ConfigError(f"pedestrian: unknown test(s) {', '.join(map(repr, unknown))}; choose from "
                          f"{', '.join(TESTS)} or all")
    data = read_config(config, "pedestrian study") if config is not None else {}
    given = {"runs": runs, "test4_runs": test4_runs, "stress_runs": stress_runs, "birth": birth, "seed": seed,
             "jobs": jobs, "beyond": beyond,
             "tests": None if not tests else (TESTS if tests == ["all"] else tuple(tests))}
    data |= {k: v for k, v in given.items() if v is not None}
    cfg = validated(PedestrianStudyConfig, data, str(config or "the command line"), "pedestrian study")
    refuse_existing(out, overwrite)
    results = run_pedestrian_study(cfg)
    kept, timing = split_timing(results)

    def report(directory: Path, _: dict) -> None:
        write_json(directory / PEDESTRIAN_TIMING, timing)
        write_pedestrian_report(directory, results)

    write_results_directory(out, overwrite, PEDESTRIAN_RESULTS, kept, report)
    Console().print(f"pedestrian study: {results['runtime_s']:.0f} s; report: {out / REPORT_HTML}")
