"""CLI commands that bring outside data in: ``nnda import-detections`` (a user's recorded detections) and
``nnda import-stonesoup`` (a scene of Stone Soup's simulators; Stone Soup is imported only when it runs)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console

from nnda.data.detections_import import SCAN_TOLERANCE_S, import_detections
from nnda.data.geodesy import parse_origin
from nnda.data.import_sensors import load_sensors, sensor_fields
from nnda.errors import ConfigError
from nnda.files import check_output_location
from nnda.peers import require_stonesoup


def import_detections_command(
    file: Annotated[Path, typer.Argument(help="detections file: .csv (or .csv.gz, .csv.bz2, .csv.zst) or .parquet")],
    out: Annotated[Path, typer.Option(help="dataset directory to write")],
    truth: Annotated[Path | None, typer.Option(
        help="truth file (.csv or .parquet): time, target_id, x, y (or lat, lon), vx, vy (optional: derived "
             "from each target's positions)")] = None,
    truth_from_labels: Annotated[float | None, typer.Option(
        metavar="GAP_S", help="without --truth: the truth at the scan times from the labelled reports (target_id), "
        "each label's position interpolated between its reports at most GAP_S s apart")] = None,
    sensors: Annotated[Path | None, typer.Option(
        help="TOML file of \\[\\[sensors]] tables (fields as in a scenario's sensors)")] = None,
    sensor: Annotated[list[str] | None, typer.Option(
        help="FIELD=VALUE of the one sensor (repeatable), e.g. scan_period_s=2, sigma_range_m=30; "
             "targets=ships|aircraft|pedestrians declares what it watches (the trackers' speed window and motion "
             "noise)")] = None,
    column: Annotated[list[str] | None, typer.Option(
        help="NAME=COLUMN: read nnda's column NAME from the file's COLUMN (repeatable), e.g. time=t_sec")] = None,
    azimuth_unit: Annotated[str, typer.Option(help="unit of the azimuth column: rad or deg")] = "rad",
    distance_unit: Annotated[str, typer.Option(
        help="unit of the range, x, y, alt columns (both files): m, km, nmi or ft; stored in m")] = "m",
    speed_unit: Annotated[str, typer.Option(
        help="unit of the truth's vx, vy columns: m/s, kn or km/h; stored in m/s")] = "m/s",
    scan_tolerance: Annotated[float, typer.Option(
        help="s: a detection belongs to the sweep within this of its time")] = SCAN_TOLERANCE_S,
    time_origin: Annotated[float | None, typer.Option(
        help="s subtracted from every time (nnda's scans lie at t > 0; default 0, or for dates and times a "
             "window or period before the first; dates and times: seconds since 1970 UTC)")] = None,
    name: Annotated[str | None, typer.Option(help="scenario name (default: the file's stem)")] = None,
    overwrite: Annotated[bool, typer.Option(help="replace an existing dataset at --out")] = False,
    delimiter: Annotated[str, typer.Option(
        help="CSV field separator: ',' ';' '|' or a tab ('\\t')")] = ",",
    decimal: Annotated[str, typer.Option(
        help="CSV decimal mark: '.' or ',' (with --delimiter ';', e.g.)")] = ".",
    encoding: Annotated[str, typer.Option(
        help="CSV text encoding, e.g. utf-8, latin-1, cp1252, utf-16")] = "utf-8",
    origin: Annotated[str | None, typer.Option(
        help="LAT,LON[,ALT] (deg, deg, m): the origin of the local east-north plane for lat/lon input "
             "(default: the first sensor's lat/lon site, else the reports' mean position)")] = None,
    region: Annotated[str | None, typer.Option(
        help="keep only reports inside: xmin,ymin,xmax,ymax (m), lat:LAT0,LAT1,lon:LON0,LON1 (deg), or a "
             "polygon file (.csv/.parquet: x,y or lat,lon vertex columns)")] = None,
) -> None:
    """Import recorded detections (CSV or Parquet) as an nnda dataset: scans grouped by sensor and sweep time.

    Columns: time (s, or dates and times: ISO 8601 text, UTC without a
    zone); range (m) and azimuth, x and y (m), or lat and lon
    (deg; optional alt, m); optional sensor (name or index) and target_id
    (empty: clutter). A sensor's period, offset and range limits not given
    are inferred from the data; its site may be given as lat=, lon=. A
    sensor with reports=true (AIS, ADS-B) keeps each report's own time and
    groups them into windows of its scan_period_s (which it must give).

    A CSV is UTF-8 with ',' between fields and '.' in numbers unless
    --encoding, --delimiter and --decimal say otherwise (a file with ';'
    and decimal commas: --delimiter ';' --decimal ','); they apply to the
    truth file too. Parquet files ignore them.
    """
    if sensors is not None and sensor:
        raise ConfigError("give the sensors either as --sensors FILE or as --sensor FIELD=VALUE, not both")
    check_output_location(out, [p for p in (file, truth, sensors) if p is not None])
    if origin is not None:
        parse_origin(origin)  # a malformed --origin is refused before any file is read
    specs = load_sensors(sensors) if sensors is not None else [sensor_fields(sensor or [])]
    path, ds = import_detections(file, out, overwrite, sensors=specs, truth=truth, columns=column,
                                 azimuth_unit=azimuth_unit, scan_tolerance=scan_tolerance,
                                 time_origin=time_origin, name=name, delimiter=delimiter, decimal=decimal,
                                 encoding=encoding, origin=origin, region=region, distance_unit=distance_unit,
                                 speed_unit=speed_unit, truth_from_labels=truth_from_labels)
    d = ds.detections
    labelled = int((~d.is_clutter).sum())
    Console().print(f"wrote {path} ({d.scan.size} detections, {labelled} of targets; {ds.n_scans} scans; "
                    f"{ds.truth.scan.size} truth rows)", markup=False, highlight=False)
    if ds.time_origin_utc is not None:
        Console().print(f"  time origin: {ds.time_origin_utc} (times are seconds after it)", markup=False,
                        highlight=False)
    if ds.geodetic_origin is not None:
        Console().print(f"  geodetic origin: {ds.geodetic_origin} (x east, y north on its tangent plane)",
                        markup=False, highlight=False)
    if "--region" in ds.dropped_rows:
        Console().print(f"  --region: {ds.dropped_rows['--region']} report(s) outside dropped", markup=False,
                        highlight=False)
    shift = 0.0 if ds.time_origin_utc is not None else time_origin or 0.0  # offsets in the file's clock
    if truth_from_labels is not None:
        labelled = len({t.name for t in ds.scenario.targets})
        Console().print(f"  truth from the labels: {np.unique(ds.truth.target_id).size} of the {labelled} labels "
                        f"have truth rows (between reports at most {truth_from_labels:g} s apart)", markup=False,
                        highlight=False)
    for spec, s in zip(specs, ds.scenario.sensors):
        timing = (f"reports in windows of {s.scan_period_s:g} s" if s.reports else f"period {s.scan_period_s:g} s")
        # a sensor whose kind is not given measures positions when the file has no range/azimuth
        kind = s.kind if "kind" in spec or s.kind == "polar" else "position: no kind given, no range/azimuth columns"
        declared = "" if s.declared_pd is None else f", declared P_D {s.declared_pd:g} (the trackers assume it)"
        if s.declared_targets is not None:
            declared += f", watches {s.declared_targets} (the trackers' speed window and motion noise)"
        Console().print(f"  sensor {s.name} ({kind}) at ({s.x_m:g}, {s.y_m:g}) m: {timing}, "
                        f"offset {s.scan_offset_s + shift:g} s, ranges {s.min_range_m:g}-{s.max_range_m:g} m"
                        f"{declared}", markup=False, highlight=False)


def import_stonesoup(
    out: Annotated[Path, typer.Option(help="output dataset directory")],
    seed: Annotated[int, typer.Option(min=0, help="seed of every Stone Soup random draw")] = 0,
    scans: Annotated[int, typer.Option(min=1, help="scans to simulate")] = 60,
    targets: Annotated[int, typer.Option(min=0, help="targets at the first scan")] = 4,
    birth_rate: Annotated[float, typer.Option(min=0, help="mean targets born per scan (Poisson)")] = 0.02,
    clutter: Annotated[float, typer.Option(min=0, help="mean clutter contacts per scan (Poisson)")] = 100.0,
    pd: Annotated[float, typer.Option(min=0, max=1, help="detection probability")] = 0.9,
    overwrite: Annotated[bool, typer.Option(help="replace an existing output directory")] = False,
) -> None:
    """Simulate a scene with Stone Soup's ground-truth and detection simulators; write an nnda dataset."""
    check_output_location(out)
    require_stonesoup("nnda import-stonesoup")
    from nnda.data.scenario import Sensor
    from nnda.peers.importer import StoneSoupScene
    from nnda.peers.importer import import_stonesoup as run

    scene = StoneSoupScene(n_scans=scans, targets=targets, birth_rate=birth_rate, clutter=clutter,
                           sensor=Sensor(pd=pd))
    path = run(out, scene, seed, overwrite)
    Console().print(f"wrote {path} (Stone Soup scene, seed {seed}, {scans} scans)", markup=False, highlight=False)
