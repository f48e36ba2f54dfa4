"""``nnda reproduce``: every reference work's study at a stated size, and one report of their claims' verdicts.

    nnda reproduce --out repro --quick        # a few minutes on 2 cores
    nnda reproduce --out repro --dask HOST:8786   # the full size, on a cluster

Writes ``OUT/data/train`` and ``OUT/models`` (the radar thesis's networks,
trained as ``make demo`` trains them), one study directory per reference
work (``radar``: Vargas Avila 2015, S1-S6; ``harbour``: Lima 2022;
``pedestrian``: Frencl 2014; ``reentry``: Pavlov & Bruno 2003; ``tbd``:
Bruno, Araújo & Pavlov), each with its own report, and ``OUT/report.html``
whose first table is every claim with the reference's number, nnda's with
its interval, and the verdict (`nnda.reports.reproduction`). The sizes are
`SIZES`; every study resumes (``--resume``) and runs on local processes or
a Dask cluster.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from nnda.app import data_commands
from nnda.app.model_commands import train_thesis_models
from nnda.app.study_commands import Dask, Jobs, Overwrite, Resume, run_study, shipped_study
from nnda.errors import ConfigError

#: the runs of each study at each size: the overrides of its shipped study file (the radar thesis's comparison
#: is `nnda.study.config.default_study`, whose runs are given here)
SIZES: dict[str, dict[str, dict]] = {
    "quick": {"radar": {"runs": 3}, "harbour": {"runs": 4},
              "pedestrian": {"pedestrian": {"runs": 20, "test4_runs": 40, "stress_runs": 4}},
              "reentry": {"reentry": {"runs": 20}}, "tbd": {"tbd": {"runs": 20, "exit_reentry": {"runs": 5}}}},
    "full": {"radar": {"runs": 100}, "harbour": {}, "pedestrian": {}, "reentry": {}, "tbd": {}},
}
#: the reproduction's studies (its directories under --out), in report order
STUDIES = tuple(SIZES["full"])


def reproduce(
    out: Annotated[Path, typer.Option(help="directory for the models, the studies and the report")],
    quick: Annotated[bool, typer.Option(help="the quick size (a few minutes on 2 cores); default: the full size, "
                                             "hours on 2 cores, what a cluster is for")] = False,
    only: Annotated[list[str] | None, typer.Option(help=f"run only these studies ({', '.join(STUDIES)}; "
                                                        "repeatable)")] = None,
    seed: Annotated[int, typer.Option(min=0, help="seed of every study and of the networks' training")] = 0,
    resume: Resume = False,
    dask: Dask = None,
    jobs: Jobs = 2,
    overwrite: Overwrite = False,
) -> None:
    """Reproduce the five reference works' studies and write one report of their claims against nnda's
    numbers, with the verdict each interval gives."""
    from nnda.reports.reproduction import write_reproduction  # the reports and the engine: when it runs
    from nnda.study.config import default_study

    names = list(only or STUDIES)
    unknown = [n for n in names if n not in STUDIES]
    if unknown:
        raise ConfigError(f"--only: unknown study {', '.join(map(repr, unknown))}; choose from {', '.join(STUDIES)}")
    size = "quick" if quick else "full"
    console = Console()
    start = time.perf_counter()
    studies = {}
    for name in names:
        overrides = SIZES[size][name]
        if name == "radar":
            data = out / "data" / "train"
            data_commands.generate(preset="train", out=data, seed=seed, overwrite=True)
            models = train_thesis_models(data, out / "models", seed)
            studies[name] = (default_study(models / "gd", models / "lm", models / "ext", seed=seed, **overrides),
                             "the radar thesis's comparison")
        else:
            studies[name] = shipped_study(name, overrides, seed)
    for name, (study, where) in studies.items():
        console.print(f"[bold]{name}[/bold]: {study.description}", highlight=False)
        run_study(study, out / name, where, resume, jobs, dask, overwrite)
    page = write_reproduction(out, {name: out / name for name in studies}, size)
    console.print(f"reproduction ({size}) in {time.perf_counter() - start:.0f} s; report: {page}")
