"""CLI command that runs one tracker on one dataset and writes its tracks, plots and scores: ``nnda track``."""

from __future__ import annotations

import enum
import math
import time
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from nnda.errors import ConfigError, OutputError
from nnda.files import atomic_directory, check_output_location, dumps
from nnda.study.metrics import DEFAULT_CUTOFF_M, OWNERSHIP


class TableFormat(str, enum.Enum):
    parquet = "parquet"
    csv = "csv"


OwnershipChoice = enum.Enum("OwnershipChoice", {o: o for o in OWNERSHIP}, type=str)


def write_track_outputs(out: Path, dataset, run, params: dict, cutoff_m: float, table_format: str = "parquet",
                        overwrite: bool = False) -> Path:
    """Write ``tracks.<format>``, ``tracks.png``, ``tracks.html`` and (with truth) ``scores.json`` into the
    directory ``out``, atomically as a whole."""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    from nnda.reports.track_plot import track_html, track_png
    from nnda.study.track import scores_record

    if out.exists() and not out.is_dir():
        raise OutputError(f"--out {out}: is a file; give a directory for the tracks, plots and scores")
    with atomic_directory(out, overwrite) as tmp:
        with open(tmp / f"tracks.{table_format}", "wb") as f:
            if table_format == "csv":
                pacsv.write_csv(run.table, f)
            else:
                pq.write_table(run.table, f)
        (tmp / "tracks.png").write_bytes(track_png(dataset, run.table, run.tracker))
        (tmp / "tracks.html").write_text(track_html(dataset, run.table, run.tracker))
        if run.scores is not None:
            (tmp / "scores.json").write_text(dumps(scores_record(run, dataset, params, cutoff_m)))
    return out


def _scores_table(record: dict) -> Table:
    from nnda.study.measures import RUN_MEASURES

    table = Table(title=f"{record['tracker']} on {record['scenario']} (ownership by {record['ownership']})")
    table.add_column("measure")
    table.add_column("value", justify="right")
    for m in RUN_MEASURES:
        v = record["metrics"].get(m.key)
        table.add_row(m.title, "-" if v is None else (f"{v:d}" if isinstance(v, int) else m.fmt.format(v * m.scale)))
    return table


def track(
    dataset: Annotated[Path, typer.Argument(help="dataset directory (one dataset, not a collection)")],
    tracker: Annotated[str, typer.Option(help="registered tracker: mht, gnn, jpda, nn, gmphd, ekphd, ...")],
    out: Annotated[Path, typer.Option(help="directory for tracks, plots and scores")],
    model: Annotated[Path | None, typer.Option(help="model file or directory (the nn tracker)")] = None,
    config: Annotated[Path | None, typer.Option(help="tracker config (.toml or .json): the tracker's params")] = None,
    format: Annotated[TableFormat, typer.Option(help="format of the track table")] = TableFormat.parquet,
    cutoff: Annotated[float, typer.Option(help="GOSPA cut-off and position-matching threshold, m")
                      ] = DEFAULT_CUTOFF_M,
    ownership: Annotated[OwnershipChoice, typer.Option(help="track ownership of the scores")
                         ] = OwnershipChoice("auto"),
    quiet: Annotated[bool, typer.Option(help="no progress bar and no score table")] = False,
    overwrite: Annotated[bool, typer.Option(help="replace an existing directory at --out")] = False,
) -> None:
    """Run one tracker on one dataset: tracks.parquet (or .csv), tracks.png, tracks.html, and scores.json where
    the dataset has truth (the study's measures)."""
    from nnda.study.track import load, run_tracker, scores_record, tracker_params
    from nnda.tracking.registry import check_config

    if not (cutoff > 0 and math.isfinite(cutoff)):
        raise ConfigError(f"--cutoff {cutoff!r}: must be a positive number of metres")
    check_output_location(out, [p for p in (dataset, model, config) if p is not None])
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: already exists (pass --overwrite to replace it)")
    ds = load(dataset)
    params = tracker_params(config, model)
    if config is not None:  # the file's fields checked against this tracker, the file named in any error
        check_config(tracker, params, f"tracker config {config}")
    console = Console()
    bar = Progress(TextColumn(f"{tracker} on {ds.scenario.name}"), BarColumn(), MofNCompleteColumn(),
                   TimeElapsedColumn(), TimeRemainingColumn(), console=console, transient=True,
                   disable=quiet or not console.is_terminal)
    task = bar.add_task("scans", total=ds.n_scans)
    start = time.perf_counter()
    with bar:
        run = run_tracker(ds, tracker, params, cutoff_m=cutoff, ownership=ownership.value,
                          on_scan=lambda done, _total: bar.update(task, completed=done))
    write_track_outputs(out, ds, run, params, cutoff, format.value, overwrite)
    wall = time.perf_counter() - start
    own = float(run.step_seconds.sum())

    def say(text: str) -> None:
        console.print(text, markup=False, highlight=False)

    if run.scores is not None and not quiet:
        console.print(_scores_table(scores_record(run, ds, params, cutoff)))
    say(f"{tracker}: {run.table.num_rows} track reports over {ds.n_scans} scans; tracker {own:.2f} s "
        f"({1e3 * own / max(ds.n_scans, 1):.2f} ms/scan), total {wall:.2f} s")
    say(f"wrote {out}" + ("" if run.scores is not None else " (no truth in the dataset: no scores)"))
