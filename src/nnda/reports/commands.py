"""CLI commands of the reports stage."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from nnda.data.dataset import read_dataset


def plot_scenario(
    dataset: Annotated[Path, typer.Argument(help="dataset directory")],
    out: Annotated[Path, typer.Option(help="PNG file to write")],
) -> None:
    """Plot a dataset: coverage, clutter, target contacts and true tracks."""
    from nnda.reports.scenario_plot import plot_scenario as draw  # matplotlib only when plotting

    draw(read_dataset(dataset), out)
    Console().print(f"wrote {out}")


def report(
    study_dir: Annotated[Path, typer.Argument(help="study directory written by `nnda compare`")],
) -> None:
    """Rebuild report.md and report.html of a study directory from its saved results."""
    from nnda.reports.study_report import write_report  # matplotlib and plotly only when reporting

    Console().print(f"report: {write_report(study_dir)}")
