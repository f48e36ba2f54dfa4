"""The ``nnda`` command line: generate datasets, train models, compare trackers, write reports.

Commands of each stage live beside the stage (``nnda.data.commands``,
``nnda.models.commands``, ...) and are registered on one typer app here.
Errors from bad input (nnda.errors.NndaError) are printed without a
traceback and exit with status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from nnda.data import commands as data_commands
from nnda.models import commands as model_commands
from nnda.reports import commands as report_commands
from nnda.data.dataset import collection_members
from nnda.data.presets import GROUPS
from nnda.errors import NndaError

app = typer.Typer(
    name="nnda",
    help="Data association in radar multi-target tracking: datasets, models, comparisons.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

app.command("presets")(data_commands.presets)
app.command("generate")(data_commands.generate)
app.command("train")(model_commands.train)
app.command("evaluate")(model_commands.evaluate)
app.command("plot-scenario")(report_commands.plot_scenario)


def demo(
    out: Annotated[Path, typer.Option(help="directory for everything the demo writes")] = Path("demo"),
    seed: Annotated[int, typer.Option(help="seed of every random draw")] = 0,
) -> None:
    """Run the whole job: generate every preset and plot each scenario."""
    data = out / "data"
    for group in GROUPS:
        data_commands.generate(preset=group, out=data / group, seed=seed, overwrite=True)
    plots = out / "scenarios"
    plots.mkdir(parents=True, exist_ok=True)
    for group in ("train", "validation"):
        for member in collection_members(data / group):
            report_commands.plot_scenario(member, plots / f"{member.name}.png")
    Console().print(f"demo written to {out}/")


app.command("demo")(demo)


def main() -> None:
    """Entry point: run the app, turning nnda's input errors into one clear message."""
    try:
        app()
    except (NndaError, FileExistsError) as exc:
        Console(stderr=True).print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
        sys.exit(2)
