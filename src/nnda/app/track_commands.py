"""CLI command that runs one tracker on one dataset and writes its tracks, plots and scores: ``nnda track``.

With ``--lag L`` (L > 0) it also writes the fixed-lag output (`nnda.tracking.lag`) beside the online one:
``tracks_lag<L>.<format>`` (the same columns and rows as ``tracks.<format>``, each scan's tracks revised
with the L scans after it) and, in ``scores.json``, ``lagged``: ``{"lag": L, "metrics": {...}}``, every run
measure of the lagged output; the online ``metrics`` stay the headline.
"""

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
from nnda.tracking.output import MAX_LAG


class TableFormat(str, enum.Enum):
    parquet = "parquet"
    csv = "csv"


OwnershipChoice = enum.Enum("OwnershipChoice", {o: o for o in OWNERSHIP}, type=str)


def write_track_outputs(out: Path, dataset, run, params: dict, cutoff_m: float, table_format: str = "parquet",
                        overwrite: bool = False, lagged=None, lag: int = 0) -> Path:
    """Write ``tracks.<format>``, ``tracks.png``, ``tracks.html`` and ``scores.json`` (its ``metrics`` null
    without truth) into the directory ``out``, atomically as a whole; with ``lagged`` (the `TrackRun` of the
    fixed-lag output of ``lag`` scans) also ``tracks_lag<lag>.<format>`` and the lagged scores in
    ``scores.json``. A dataset with a geodetic origin gets ``lat``, ``lon`` (deg, at the origin's height) after
    the state columns of each table."""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    from nnda.reports.track_plot import track_html, track_png

    if out.exists() and not out.is_dir():
        raise OutputError(f"--out {out}: is a file; give a directory for the tracks, plots and scores")
    with atomic_directory(out, overwrite) as tmp:
        tables = [("tracks", run.table)] + ([] if lagged is None else [(f"tracks_lag{lag}", lagged.table)])
        for name, table in tables:
            table = _with_degrees(table, dataset.geodetic_origin)
            with open(tmp / f"{name}.{table_format}", "wb") as f:
                if table_format == "csv":
                    pacsv.write_csv(table, f)
                else:
                    pq.write_table(table, f)
        (tmp / "tracks.png").write_bytes(track_png(dataset, run.table, run.tracker))
        (tmp / "tracks.html").write_text(track_html(dataset, run.table, run.tracker))
        (tmp / "scores.json").write_text(dumps(_scores(run, dataset, params, cutoff_m, lagged, lag)))
    return out


def _with_degrees(table, origin):
    """``table`` with ``lat``, ``lon`` (deg) of its x, y (m) inserted after ``vy``; as it is without an
    ``origin``."""
    if origin is None:
        return table
    import pyarrow as pa

    x, y = (table.column(c).to_numpy(zero_copy_only=False) for c in ("x", "y"))
    lat, lon = origin.on_surface(x, y)
    at = table.schema.get_field_index("vy") + 1
    return table.add_column(at, "lat", pa.array(lat)).add_column(at + 1, "lon", pa.array(lon))


def _scores(run, dataset, params: dict, cutoff_m: float, lagged, lag: int) -> dict:
    """``scores.json``'s record (`nnda.study.track.scores_record`), with ``lagged`` = {lag, metrics} of the
    fixed-lag run when there is one."""
    from nnda.study.track import scores_record
    from nnda.study.track_job import scalars

    record = scores_record(run, dataset, params, cutoff_m)
    if lagged is not None and lagged.scores is not None:
        record["lagged"] = {"lag": lag, "metrics": scalars(lagged.scores)}
    return record


def _scores_table(record: dict) -> Table:
    from nnda.study.measures import RUN_MEASURES

    table = Table(title=f"{record['tracker']} on {record['scenario']} (ownership by {record['ownership']})")
    table.add_column("measure")
    table.add_column("value", justify="right")
    late = record.get("lagged")
    if late is not None:
        table.add_column(f"lag {late['lag']}", justify="right")

    def shown(m, v) -> str:
        return "-" if v is None else (f"{v:d}" if isinstance(v, int) else m.fmt.format(v * m.scale))

    for m in RUN_MEASURES:
        row = [m.title, shown(m, record["metrics"].get(m.key))]
        if late is not None:
            row.append(shown(m, late["metrics"].get(m.key)))
        table.add_row(*row)
    return table


def _per_scan(seconds) -> str:
    """The tracker's time per scan, the first scan apart: it loads (or, on a fresh install, compiles) the
    compiled kernels, a one-off cost that is not the tracker's per-scan work."""
    if len(seconds) < 2:
        return f"{1e3 * float(sum(seconds)):.2f} ms/scan"
    return (f"{1e3 * float(seconds[1:].mean()):.2f} ms/scan after the first, which took {1e3 * float(seconds[0]):.0f} "
            f"ms with the compiled kernels' loading")


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
    lag: Annotated[int, typer.Option(min=0, max=MAX_LAG, help="also write and score the fixed-lag output, each "
                                     "scan revised with the LAG scans after it (tracks_lag<LAG>.<format>); 0: "
                                     "online only")] = 0,
    quiet: Annotated[bool, typer.Option(help="no progress bar and no score table")] = False,
    overwrite: Annotated[bool, typer.Option(help="replace an existing directory at --out")] = False,
) -> None:
    """Run one tracker on one dataset: tracks.parquet (or .csv), tracks.png, tracks.html, and scores.json where
    the dataset has truth (the study's measures); with --lag L also tracks_lag<L>.parquet and its scores."""
    from nnda.app.api import lagged_runs
    from nnda.study.track import load, run_tracker, tracker_params
    from nnda.tracking.registry import check_config

    if not (cutoff > 0 and math.isfinite(cutoff)):
        raise ConfigError(f"--cutoff {cutoff!r}: must be a positive number of metres")
    check_output_location(out, [p for p in (dataset, model, config) if p is not None])
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: already exists (pass --overwrite to replace it)")
    ds = load(dataset)
    params = tracker_params(config, model)
    if config is not None:  # the file's fields checked against this tracker, the file named in any error
        check_config(tracker, params, f"tracker config {config}", ds.scenario.sensors)
    console = Console()
    bar = Progress(TextColumn(f"{tracker} on {ds.scenario.name}"), BarColumn(), MofNCompleteColumn(),
                   TimeElapsedColumn(), TimeRemainingColumn(), console=console, transient=True,
                   disable=quiet or not console.is_terminal)
    task = bar.add_task("scans", total=ds.n_scans)
    start = time.perf_counter()
    with bar:
        on_scan = lambda done, _total: bar.update(task, completed=done)  # noqa: E731
        if lag:
            run, late = lagged_runs(ds, tracker, params, lag, cutoff, ownership.value, on_scan)
        else:
            run, late = run_tracker(ds, tracker, params, cutoff_m=cutoff, ownership=ownership.value,
                                    on_scan=on_scan), None
    write_track_outputs(out, ds, run, params, cutoff, format.value, overwrite, late, lag)
    wall = time.perf_counter() - start
    own = float(run.step_seconds.sum())

    def say(text: str) -> None:
        console.print(text, markup=False, highlight=False)

    if run.scores is not None and not quiet:
        console.print(_scores_table(_scores(run, ds, params, cutoff, late, lag)))
    say(f"{tracker}: {run.table.num_rows} track reports over {ds.n_scans} scans; tracker {own:.2f} s "
        f"({_per_scan(run.step_seconds)}), total {wall:.2f} s")
    if run.detection is not None:
        say(f"{tracker}: {run.detection.line()}")
        learnt = (run.management or {}).get("learnt_pd")
        if learnt is not None:
            say(f"{tracker}: P_D learnt from the confirmed tracks by the run's end: " + ", ".join(
                f"{name} {value:.3f}" + (" (as assumed: their record is not below it)" if value == assumed else "")
                for name, value, assumed in zip(run.detection.sensors, learnt, run.detection.values)
                if value is not None))
    if run.targets is not None:
        say(f"{tracker}: {run.targets.line()}")
    if late is not None:
        extra = float(late.step_seconds.sum())
        say(f"lag {lag}: tracks_lag{lag}.{format.value}, the revision {extra:.2f} s "
            f"({extra / own if own > 0 else 0.0:.2f}x the tracker's time)")
    say(f"wrote {out}" + ("" if run.scores is not None else " (no truth in the dataset: scores.json records the "
                             "run, its metrics null)"))
