"""CLI commands that run a study or draw from one: ``nnda run`` (alias ``nnda compare``: run a study file, then
report), ``nnda report``, ``nnda plot-scenario``, and ``nnda reentry``, ``nnda tbd`` and ``nnda pedestrian``, which
run the reference works' study files shipped with nnda."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from nnda.errors import ConfigError, OutputError
from nnda.files import check_output_location, read_config

# The study engine and the reports load the trackers, matplotlib and plotly: each command imports what it runs
# when it runs, so `nnda --help` and the other commands start quickly.
#: the pedestrian study's tests (`nnda.study.pedestrian.TESTS`)
PEDESTRIAN_TESTS = ("test1", "test2", "test3", "test4")


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
    from nnda.data.dataset import read_dataset

    check_output_location(out, [dataset])
    draw(read_dataset(dataset), out)
    Console().print(f"wrote {out}", markup=False, highlight=False)


def report(
    study_dir: Annotated[Path, typer.Argument(help="study directory written by `nnda compare`")],
) -> None:
    """Rebuild report.md and report.html of a study directory from its saved results."""
    from nnda.reports.study_report import write_report  # matplotlib and plotly only when reporting

    Console().print(f"report: {write_report(study_dir)}")


def _progress(console: Console, title: str):
    """A progress bar over a study's jobs and the callback that moves it (shown once the study passed its
    checks)."""
    bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                   TextColumn("{task.fields[last]}"), TimeElapsedColumn(), TimeRemainingColumn(), console=console)
    task = bar.add_task(title, total=None, last="")

    def on_job(done: int, total: int, job) -> None:
        if job is None:
            bar.start()
        bar.update(task, completed=done, total=total, last=job.title if job is not None else "")

    return bar, on_job


def run_study(definition, out: Path, where: str, resume: bool = False, jobs: int = 2, dask: str | None = None,
              overwrite: bool = False) -> Path:
    """Run a `nnda.study.config.Study` into ``out`` with a progress bar, then write its report; returns the
    report's path."""
    from nnda.reports.study_report import write_report  # matplotlib and plotly only when reporting
    from nnda.study.compare import compare as run_comparison  # the trackers and filters: only when run

    console = Console()
    bar, on_job = _progress(console, f"{definition.name}")
    try:
        result = run_comparison(definition, out, resume=resume, workers=jobs, dask=dask, on_job=on_job,
                                where=where, overwrite=overwrite)
    finally:
        bar.stop()
    ex = result.execution
    console.print(f"{ex.jobs_run} job(s) run, {ex.jobs_skipped} resumed, on {ex.executor} in {ex.seconds:.1f} s")
    page = write_report(out)
    console.print(f"report: {page}")
    return page


Resume = Annotated[bool, typer.Option(help="continue an interrupted study in --out, skipping finished jobs")]
Dask = Annotated[str | None, typer.Option(
    help="run the jobs on Dask: a scheduler address, or 'local' for a LocalCluster (needs nnda\\[dask])")]
Jobs = Annotated[int, typer.Option(min=1, help="local worker processes (1: in this process); Dask workers with "
                                               "--dask local")]
Overwrite = Annotated[bool, typer.Option(help="replace an earlier study directory at --out")]
MaxMemory = Annotated[float | None, typer.Option(
    help="the most memory (GiB) one job or the aggregation may need by the study's estimate (the study file's "
         "max_memory_gib, at the top and in the \\[reentry], \\[tbd] and \\[pedestrian] tables; default 4): a bigger "
         "study is refused before it runs")]
#: the study-file tables whose kinds estimate their memory before they run (their field ``max_memory_gib``)
MEMORY_TABLES = ("reentry", "tbd", "pedestrian")


def memory_limit(gib: float | None) -> dict:
    """The tables' field that ``--max-memory-gib`` sets (empty when not given); ConfigError unless > 0."""
    if gib is None:
        return {}
    if not gib > 0:
        raise ConfigError(f"--max-memory-gib is {gib:g}; give the memory in GiB (> 0) a job may need")
    return {"max_memory_gib": gib}


def with_memory_limit(study, gib: float | None):
    """``study`` with ``--max-memory-gib`` set at its top level (the tracker and filter jobs) and in each of its
    `MEMORY_TABLES` (unchanged when not given)."""
    field = memory_limit(gib)
    if not field:
        return study
    tables = {name: getattr(study, name) for name in MEMORY_TABLES if getattr(study, name, None) is not None}
    return study.model_copy(update={**field, **{name: t.model_copy(update=field) for name, t in tables.items()}})


def compare(
    study: Annotated[Path, typer.Option(help="study file (.toml or .json)")],
    out: Annotated[Path, typer.Option(help="study directory for job results, aggregates and the report")],
    resume: Resume = False,
    dask: Dask = None,
    jobs: Jobs = 2,
    overwrite: Overwrite = False,
    max_memory_gib: MaxMemory = None,
) -> None:
    """Run a study file: every job of every kind it names (trackers, filters, particle-filter studies, ...),
    then write the report."""
    from nnda.study.config import load_study

    run_study(with_memory_limit(load_study(study), max_memory_gib), out, str(study), resume, jobs, dask, overwrite)


def reference_study(name: str) -> Path:
    """The study file of a reference work shipped with nnda (``nnda/studies/<name>.toml``)."""
    return Path(str(resources.files("nnda") / "studies" / f"{name}.toml"))


def shipped_study(name: str, overrides: dict, seed: int | None = None, config: Path | None = None,
                  table: str | None = None) -> tuple:
    """The study file ``name`` shipped with nnda, with ``overrides`` merged in (tables merged key by key), its
    ``[table]`` first replaced by the one in ``config`` (a file of the table's fields; a seed or confidence
    there is the study's), and the seed overridden by ``seed``. Returns the study and how messages name it."""
    from nnda.study.config import study_from_dict

    path = reference_study(name)
    data = read_config(path, "study")
    where = str(config) if config is not None else f"the shipped {path.name}"
    if config is not None:
        own = read_config(config, f"{table} study")
        data |= {k: own.pop(k) for k in ("seed", "confidence") if k in own}
        data[table] = own
    for key, value in overrides.items():
        data[key] = {**data.get(key, {}), **value} if isinstance(value, dict) and data.get(key) else value
    if seed is not None:
        data["seed"] = seed
    return study_from_dict(data, where, path.parent), where


def reentry(
    out: Annotated[Path, typer.Option(help="study directory for job results, aggregates and the report")],
    config: Annotated[Path | None, typer.Option(help="the \\[reentry] table's fields (.toml or .json; default: the "
                                                     "paper's setting, the particle sweep and the precise sensor)")
                      ] = None,
    runs: Annotated[int | None, typer.Option(min=1, help="Monte Carlo runs (overrides the config)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed (overrides the config)")] = None,
    resume: Resume = False,
    dask: Dask = None,
    jobs: Jobs = 2,
    overwrite: Overwrite = False,
    max_memory_gib: MaxMemory = None,
) -> None:
    """Run the ballistic re-entry filter study (Pavlov & Bruno 2003; the shipped studies/reentry.toml): every
    filter on the same runs, then its report."""
    table = ({} if runs is None else {"runs": runs}) | memory_limit(max_memory_gib)
    study, where = shipped_study("reentry", {"reentry": table}, seed, config, "reentry")
    run_study(study, out, where, resume, jobs, dask, overwrite)


def tbd(
    out: Annotated[Path, typer.Option(help="study directory for job results, aggregates and the report")],
    config: Annotated[Path | None, typer.Option(help="the \\[tbd] table's fields (.toml or .json; default: 100 runs x "
                                                     "20 frames at 6.5 and 8.1 dB, APF 5,000, RS 8,000, ...)")] = None,
    runs: Annotated[int | None, typer.Option(min=1, help="Monte Carlo runs (overrides the config)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed (overrides the config)")] = None,
    chain: Annotated[bool, typer.Option(help="also track the detector's detections with GNN and MHT (the "
                                             "config's `chain`; --no-chain: the detector alone)")] = True,
    resume: Resume = False,
    dask: Dask = None,
    jobs: Jobs = 2,
    overwrite: Overwrite = False,
    max_memory_gib: MaxMemory = None,
) -> None:
    """Run the track-before-detect study (Bruno, Araújo & Pavlov; the shipped studies/tbd.toml): every filter
    on the same frames, the detector and the detect-then-track chain, then its report."""
    table = (({} if runs is None else {"runs": runs}) | ({} if chain else {"chain": None})
             | memory_limit(max_memory_gib))
    study, where = shipped_study("tbd", {"tbd": table}, seed, config, "tbd")
    run_study(study, out, where, resume, jobs, dask, overwrite)


def pedestrian(
    out: Annotated[Path, typer.Option(help="study directory for job results, aggregates and the report")],
    tests: Annotated[list[str] | None, typer.Argument(help="test1, test2, test3, test4 (default: all)")] = None,
    config: Annotated[Path | None, typer.Option(help="the \\[pedestrian] table's fields (.toml or .json)")] = None,
    runs: Annotated[int | None, typer.Option(min=2, help="accuracy runs of Tests 2-3 (default 300)")] = None,
    test4_runs: Annotated[int | None, typer.Option(min=2, help="runs of Test 4 (default 600)")] = None,
    stress_runs: Annotated[int | None, typer.Option(min=2, help="runs of the stress scenes (default 25)")] = None,
    birth: Annotated[str | None, typer.Option(help="measurement (default) or oracle (the thesis's)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed (overrides the config)")] = None,
    beyond: Annotated[bool | None, typer.Option(help="also GNN, JPDA, MHT and CPHD on the stress scene")] = None,
    resume: Resume = False,
    dask: Dask = None,
    jobs: Jobs = 2,
    overwrite: Overwrite = False,
    max_memory_gib: MaxMemory = None,
) -> None:
    """Run the pedestrian study (Frencl 2014, Tests 1-4: PHD filters and motion models on walkers; the shipped
    studies/pedestrian.toml), then its report."""
    unknown = [t for t in tests or () if t not in (*PEDESTRIAN_TESTS, "all")]
    if unknown:
        raise ConfigError(f"pedestrian: unknown test(s) {', '.join(map(repr, unknown))}; choose from "
                          f"{', '.join(PEDESTRIAN_TESTS)} or all")
    given = {"runs": runs, "test4_runs": test4_runs, "stress_runs": stress_runs, "birth": birth, "beyond": beyond,
             "tests": None if not tests else (list(PEDESTRIAN_TESTS) if tests == ["all"] else list(tests)),
             **memory_limit(max_memory_gib)}
    study, where = shipped_study("pedestrian", {"pedestrian": {k: v for k, v in given.items() if v is not None}},
                                 seed, config, "pedestrian")
    run_study(study, out, where, resume, jobs, dask, overwrite)
