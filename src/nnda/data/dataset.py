"""Datasets in memory and on disk.

A dataset directory holds ``scenario.json`` (manifest: format, version, seed,
run, the validated scenario with its sensors), ``detections.parquet`` and
``truth.parquet``. A *collection* directory (a Monte Carlo set or a preset
group) holds one dataset directory per member and a ``collection.json``
manifest listing them. Everything is written to a temporary sibling and
renamed into place, so a failed write leaves nothing behind; readers check
format, version and schema and name the file and field they refuse.

Format versions: 4 (written) is 3 plus the SHA-256 of the manifest's own
canonical content in its ``manifest_sha256`` field, checked on read, so a
hand-edited ``scenario.json`` (its scenario, its counts, its format
version) is refused rather than read; 3 is 2 plus the SHA-256 of
``detections.parquet`` and ``truth.parquet`` in the manifest's ``sha256``
field, checked on read, so a flipped byte is a "corrupt file" error rather
than data; a manifest holding a field of a later version than it names is
refused as edited (so are ``geodetic_origin`` and ``dropped_rows``, optional
fields since format 4, in an older manifest); 2 has a
``sensor`` column in ``detections.parquet``, the index of the detecting
sensor in the manifest's ``scenario.sensors``; 1 (one radar at the origin,
the scenario in the one-sensor form) has no such column (read as all 0).
Versions 1 and 2 still read, without the digest check, and 3 without the
seal, when their manifest's ``nnda_version`` is a release that wrote that
format (`FIRST_WRITER`): a newer dataset relabelled as an older format, its
digests or seal dropped, is refused rather than read unverified. The data
files, and a collection's members, must lie in their directory (no symbolic
link out of it).

Every dataset read or written passes `check_dataset`: values a tracker or a
trainer would take at face value must be plausible (positive ranges,
azimuths in [0, 2 pi), x/y agreeing with range/azimuth from the detecting
sensor, times of the scan schedule, rows in scan order), each refusal naming
the file, the column and the row. A collection must hold exactly the members
its manifest lists.

An imported dataset may record, in its manifest, the geodetic origin of its
frame (``geodetic_origin``: lat_deg, lon_deg, alt_m and how it was chosen;
`nnda.data.geodesy`: x east, y north on the tangent plane there) and the
rows an import option dropped (``dropped_rows``: option -> count), and the
instant t = 0 stands for when the imported times were dates and times
(``time_origin_utc``, ISO 8601 text in UTC). All are absent otherwise, so
datasets without them read and write as before.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from nnda.data.checks import whole_number
from nnda.data.geodesy import GeodeticOrigin
from nnda.data.scenario import Scenario, scenario_from_dict
from nnda.data.sensor import TWO_PI, polar_to_cart
from nnda.errors import ConfigError, DatasetError
from nnda.files import (
    atomic_directory,
    digest,
    dumps,
    file_digests,
    listed_file,
    path_component,
    read_json,
    verify_digests,
)
from nnda.version import __version__

FORMAT = "nnda.dataset"
COLLECTION_FORMAT = "nnda.collection"
FORMAT_VERSION = 4
#: dataset format versions `read_dataset` reads (1: one radar, no ``sensor`` column; 1 and 2: no digests)
READABLE_VERSIONS = (1, 2, 3, 4)
#: the first format version whose manifest records the SHA-256 of its data files
DIGESTS_SINCE = 3
#: the manifest's own SHA-256 (``manifest_sha256``) since format 4
SEALED_SINCE = 4
#: the first nnda release that wrote each format version newer than 3 (those before wrote formats 1-3): a
#: manifest of an older format that names such a writer in its field 'nnda_version' was relabelled
FIRST_WRITER = {4: (0, 2)}
COLLECTION_FORMAT_VERSION = 1
MANIFEST = "scenario.json"
COLLECTION_MANIFEST = "collection.json"
DETECTIONS_FILE = "detections.parquet"
TRUTH_FILE = "truth.parquet"
DATA_FILES = (DETECTIONS_FILE, TRUTH_FILE)
#: a detection's x/y may lie this far from the point its range/azimuth give: relative to |(x, y)| + range ...
POSITION_RTOL = 1e-6
#: ... plus this much, m
POSITION_ATOL_M = 1e-3
#: a time column may differ from the scenario's scan schedule by this much, relative to max(1 s, |t|)
TIME_RTOL = 1e-9


@dataclass(frozen=True)
class Detections:
    """All contacts of a dataset, one entry per detection; arrays of shape (N,).

    Rows are ordered by scan, then by azimuth (the order a rotating antenna
    reports them), or by time (stable) in a report sensor's scan. ``time``
    is the scan's time, or a report sensor's own time of each report (s;
    scan k's within (t_k - scan_period_s, t_k]). ``sensor`` is the index of the detecting sensor in
    ``scenario.sensors`` (None, the default, means sensor 0 for every row);
    ``range`` m and ``azimuth`` rad in [0, 2 pi) clockwise from north are
    measured from that sensor's position; ``x``/``y`` m are the detection's
    position in the scenario frame (a polar sensor's converted from its
    measured range and azimuth, a position sensor's as measured);
    ``target_id`` is the index of the originating target or -1 for clutter.
    """

    scan: np.ndarray
    time: np.ndarray
    range: np.ndarray
    azimuth: np.ndarray
    x: np.ndarray
    y: np.ndarray
    is_clutter: np.ndarray
    target_id: np.ndarray
    sensor: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.sensor is None:
            object.__setattr__(self, "sensor", np.zeros(np.shape(self.scan), dtype=np.int32))


@dataclass(frozen=True)
class Truth:
    """True target states, one row per existing target per scan; arrays of shape (M,).

    ``detected`` says whether the target has a contact in that scan.
    """

    scan: np.ndarray
    time: np.ndarray
    target_id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    detected: np.ndarray


#: ``detections.parquet`` of format version 1: no ``sensor`` column
DETECTIONS_SCHEMA_V1 = pa.schema([
    ("scan", pa.int32()), ("time", pa.float64()), ("range", pa.float64()),
    ("azimuth", pa.float64()), ("x", pa.float64()), ("y", pa.float64()),
    ("is_clutter", pa.bool_()), ("target_id", pa.int32()),
])
DETECTIONS_SCHEMA = DETECTIONS_SCHEMA_V1.append(pa.field("sensor", pa.int32()))
TRUTH_SCHEMA = pa.schema([
    ("scan", pa.int32()), ("time", pa.float64()), ("target_id", pa.int32()),
    ("x", pa.float64()), ("y", pa.float64()), ("vx", pa.float64()), ("vy", pa.float64()),
    ("detected", pa.bool_()),
])


@dataclass(frozen=True)
class Scan:
    """One sweep of one sensor as a tracker sees it: index k, time (s), measurements (N, 2), sensor.

    ``sensor`` is the sweeping sensor's index in ``scenario.sensors``. A polar
    sensor's measurements are [range m, azimuth rad] from that sensor's
    position; a position sensor's are [x m, y m] in the scenario frame.
    ``times``: for a report sensor (`nnda.data.scenario.Sensor.reports`),
    each contact's own time (s), shape (N,) float64, non-decreasing, all in
    (time - scan_period_s, time]; ``time`` is then the window's end. None
    for a sweep (every contact at ``time``).
    """

    index: int
    time: float
    measurements: np.ndarray
    sensor: int = 0
    times: np.ndarray | None = None


@dataclass(frozen=True)
class Dataset:
    """One realisation of a scenario: its config, seed, run index, contacts and truth.

    ``geodetic_origin``: where the frame's origin lies on the Earth (an
    import of geodetic data), else None; ``dropped_rows``: rows of the
    imported file an import option dropped, by option (e.g. ``--region``);
    ``time_origin_utc``: the instant (ISO 8601 text, UTC) that t = 0 stands
    for, when the imported times were absolute (dates and times), else None.
    """

    scenario: Scenario
    seed: int
    run: int
    detections: Detections
    truth: Truth
    geodetic_origin: GeodeticOrigin | None = None
    dropped_rows: dict[str, int] = field(default_factory=dict)
    time_origin_utc: str | None = None

    @property
    def n_scans(self) -> int:
        return self.scenario.n_scans

    @cached_property
    def scan_time(self) -> np.ndarray:
        """Time (s) of each scan k = 1..n_scans, shape (n_scans,)."""
        return self.scenario.scan_schedule()[0]

    @cached_property
    def scan_sensor(self) -> np.ndarray:
        """Index in ``scenario.sensors`` of the sensor sweeping each scan k = 1..n_scans, shape (n_scans,), int32."""
        return self.scenario.scan_schedule()[1]

    def scan_bounds(self) -> np.ndarray:
        """Row offsets of each scan in ``detections``: scan k is rows [b[k-1], b[k]), shape (n_scans+1,)."""
        return np.searchsorted(self.detections.scan, np.arange(1, self.n_scans + 2))

    def scans(self) -> Iterator[Scan]:
        """The sweeps in time order, including empty ones, each with its sensor's measurements (see `Scan`); a
        report sensor's scans with each report's time."""
        b = self.scan_bounds()
        d = self.detections
        by_kind = {"polar": np.column_stack([d.range, d.azimuth]), "position": np.column_stack([d.x, d.y])}
        measurements = [by_kind[s.kind] for s in self.scenario.sensors]
        reports = [s.reports for s in self.scenario.sensors]
        time_of = np.asarray(d.time, dtype=np.float64)
        for k, (time, sensor) in enumerate(zip(self.scan_time.tolist(), self.scan_sensor.tolist()), start=1):
            times = time_of[b[k - 1]:b[k]] if reports[sensor] else None
            yield Scan(k, time, measurements[sensor][b[k - 1]:b[k]], sensor, times)


# ----------------------------------------------------------------------------- writing

def _table(record, schema: pa.Schema) -> pa.Table:
    return pa.Table.from_arrays(
        [pa.array(np.asarray(getattr(record, f.name)), type=f.type) for f in schema], schema=schema
    )


def manifest(dataset: Dataset, sha256: dict[str, str]) -> dict:
    """The ``scenario.json`` content: what the dataset is, from what, with what; ``sha256`` maps each data
    file's name to its digest (`nnda.files.file_digests`)."""
    s = dataset.scenario
    head = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "nnda_version": __version__,
        "seed": dataset.seed,
        "run": dataset.run,
        "n_scans": s.n_scans,
        "n_detections": int(dataset.detections.scan.size),
        "n_clutter": int(dataset.detections.is_clutter.sum()),
        "target_names": [t.name for t in s.targets],
        "sensor_names": [sensor.name for sensor in s.sensors],
        "scenario": s.model_dump(mode="json"),
        "sha256": sha256,
    }
    if dataset.geodetic_origin is not None:
        head["geodetic_origin"] = dataset.geodetic_origin.record()
    if dataset.dropped_rows:
        head["dropped_rows"] = dict(dataset.dropped_rows)
    if dataset.time_origin_utc is not None:
        head["time_origin_utc"] = dataset.time_origin_utc
    return head | {"manifest_sha256": manifest_seal(head)}


def manifest_seal(meta: dict) -> str:
    """SHA-256 of a manifest's canonical JSON without its ``manifest_sha256`` field."""
    return digest(dumps({k: v for k, v in meta.items() if k != "manifest_sha256"}, None).encode())


def write_dataset_files(dataset: Dataset, directory: Path) -> None:
    """Write the three files of a dataset into an existing, empty ``directory``: the data files, then the
    manifest with their digests."""
    for name, record, schema in ((DETECTIONS_FILE, dataset.detections, DETECTIONS_SCHEMA),
                                 (TRUTH_FILE, dataset.truth, TRUTH_SCHEMA)):
        with open(directory / name, "wb") as f:  # closed even when a write fails (a full disk)
            pq.write_table(_table(record, schema), f)
    (directory / MANIFEST).write_text(dumps(manifest(dataset, file_digests(directory, DATA_FILES))))


def write_dataset(dataset: Dataset, out: str | Path, overwrite: bool = False) -> Path:
    """Check (`check_dataset`) and write one dataset directory atomically; returns its path."""
    check_dataset(dataset, f"dataset {out}: detections", f"dataset {out}: truth")
    with atomic_directory(out, overwrite) as tmp:
        write_dataset_files(dataset, tmp)
    return Path(out)


def write_collection(
    members: Iterator[tuple[str, Dataset]], out: str | Path, description: str,
    overwrite: bool = False, on_member: Callable[[str], None] | None = None,
) -> Path:
    """Write datasets as sub-directories of one collection, atomically as a whole.

    ``members`` yields (member name, dataset), at least one; each name must
    be a safe directory name (`nnda.files.path_component`) and appear once,
    each dataset pass `check_dataset`. ``on_member`` is called after each
    member is written (progress reporting).
    """
    names: list[str] = []
    with atomic_directory(out, overwrite) as tmp:
        for name, dataset in members:
            path_component(name, f"collection {out}: member name")
            if name in names:
                raise ConfigError(f"collection {out}: member name {name!r} is given twice")
            where = f"collection {out}: member {name!r}"
            check_dataset(dataset, f"{where}: detections", f"{where}: truth")
            (tmp / name).mkdir()
            write_dataset_files(dataset, tmp / name)
            names.append(name)
            if on_member is not None:
                on_member(name)
        if not names:
            raise ConfigError(f"collection {out}: no members to write")
        (tmp / COLLECTION_MANIFEST).write_text(dumps({
            "format": COLLECTION_FORMAT,
            "format_version": COLLECTION_FORMAT_VERSION,
            "nnda_version": __version__,
            "description": description,
            "members": names,
        }))
    return Path(out)


# ----------------------------------------------------------------------------- checks

#: the numpy dtype kind of each Parquet column type
_KIND = {pa.int32(): "i", pa.float64(): "f", pa.bool_(): "b"}


def _first(bad: np.ndarray) -> int | None:
    """Index of the first True of ``bad``, or None."""
    rows = np.flatnonzero(bad)
    return int(rows[0]) if rows.size else None


def _check_record(where: str, record, schema: pa.Schema, scan_time: np.ndarray, n_targets: int,
                  window: np.ndarray | None = None) -> None:
    """Checks shared by detections and truth: shapes, dtypes, finite floats, scans, times, target ids.
    ``window`` (s, one per row, or None: all 0): how far before its scan's time a row's time may lie (a
    report sensor's window); such rows' times must not decrease within a scan."""
    columns = {f.name: np.asarray(getattr(record, f.name)) for f in schema}
    n = columns["scan"].shape
    for f in schema:
        a = columns[f.name]
        if a.ndim != 1 or a.shape != n:
            raise DatasetError(f"{where}: column {f.name!r} has shape {a.shape}, expected {n} as column 'scan'")
        if a.dtype.kind != _KIND[f.type]:
            raise DatasetError(f"{where}: column {f.name!r} has dtype {a.dtype}, expected {f.type}")
        if a.dtype.kind == "f" and (row := _first(~np.isfinite(a))) is not None:
            raise DatasetError(f"{where}: column {f.name!r} has a non-finite value at row {row}")
    scan, n_scans = columns["scan"], scan_time.size
    if (row := _first((scan < 1) | (scan > n_scans))) is not None:
        raise DatasetError(f"{where}: column 'scan' leaves the range 1..{n_scans}: {scan[row]} at row {row}")
    if (row := _first(np.diff(scan) < 0)) is not None:
        raise DatasetError(f"{where}: column 'scan' is not in increasing order: {scan[row + 1]} at row {row + 1} "
                           f"follows {scan[row]}")
    time, scheduled = columns["time"], scan_time[scan - 1]
    slack = TIME_RTOL * np.maximum(1.0, np.abs(scheduled))
    before = np.zeros_like(scheduled) if window is None else window
    if (row := _first((time < scheduled - before - slack) | (time - scheduled > slack))) is not None:
        span = (f"in ({float(scheduled[row] - before[row])!r}, {float(scheduled[row])!r}] s, its report window"
                if before[row] > 0 else f"at {float(scheduled[row])!r} s")
        raise DatasetError(f"{where}: column 'time' is {float(time[row])!r} s at row {row}, but scan {scan[row]} is "
                           f"{span} in the scenario's scan schedule")
    back = (np.diff(time) < 0) & (np.diff(scan) == 0) & (before[1:] > 0)
    if (row := _first(back)) is not None:
        raise DatasetError(f"{where}: column 'time' goes back from {float(time[row])!r} s to "
                           f"{float(time[row + 1])!r} s at row {row + 1} within report scan {scan[row]}; a report "
                           f"scan's rows are in time order")
    tid, low = columns["target_id"], -1 if "is_clutter" in schema.names else 0
    if (row := _first((tid < low) | (tid >= n_targets))) is not None:
        raise DatasetError(f"{where}: column 'target_id' leaves the range {low}..{n_targets - 1}: {tid[row]} at "
                           f"row {row} ({n_targets} target(s) in the scenario)")


def _check_detections(where: str, dataset: Dataset) -> None:
    d, sensors = dataset.detections, dataset.scenario.sensors
    if (row := _first(d.is_clutter != (d.target_id < 0))) is not None:
        raise DatasetError(f"{where}: columns 'is_clutter' and 'target_id' disagree at row {row} "
                           f"({bool(d.is_clutter[row])}, {d.target_id[row]})")
    sensor, n_sensors = d.sensor, len(sensors)
    if (row := _first((sensor < 0) | (sensor >= n_sensors))) is not None:
        raise DatasetError(f"{where}: column 'sensor' names sensor {sensor[row]} at row {row}, but {MANIFEST} "
                           f"lists {n_sensors} sensor(s) (indices 0..{n_sensors - 1})")
    sweeping = dataset.scan_sensor[d.scan - 1]
    if (row := _first(sensor != sweeping)) is not None:
        raise DatasetError(f"{where}: column 'sensor' is {sensor[row]} at row {row}, but scan "
                           f"{d.scan[row]} is a sweep of sensor {sweeping[row]}")
    if (row := _first(~(d.range > 0))) is not None:
        raise DatasetError(f"{where}: column 'range' is {float(d.range[row])!r} m at row {row}; "
                           f"a range must be positive")
    if (row := _first((d.azimuth < 0) | (d.azimuth >= TWO_PI))) is not None:
        raise DatasetError(f"{where}: column 'azimuth' is {float(d.azimuth[row])!r} rad at row {row}, "
                           f"outside [0, 2 pi)")
    ox, oy = (np.array([s.x_m for s in sensors])[sensor], np.array([s.y_m for s in sensors])[sensor])
    px, py = polar_to_cart(d.range, d.azimuth)
    miss = np.hypot(d.x - (px + ox), d.y - (py + oy))
    tolerance = POSITION_RTOL * (np.hypot(d.x, d.y) + d.range) + POSITION_ATOL_M
    if (row := _first(miss > tolerance)) is not None:
        s = sensors[sensor[row]]
        raise DatasetError(
            f"{where}: columns 'x', 'y' at row {row} are ({d.x[row]:.3f}, {d.y[row]:.3f}) m, {miss[row]:.4g} m from "
            f"the point that columns 'range' ({d.range[row]:.3f} m) and 'azimuth' ({d.azimuth[row]:.6f} rad) give "
            f"from sensor {s.name!r} at ({s.x_m:g}, {s.y_m:g}) m (tolerance {tolerance[row]:.3g} m)")


def _check_truth(where: str, dataset: Dataset) -> None:
    t, n_targets = dataset.truth, len(dataset.scenario.targets)
    key = t.scan.astype(np.int64) * n_targets + t.target_id
    if (row := _first(np.diff(key) <= 0)) is not None:
        raise DatasetError(f"{where}: rows {row} and {row + 1} (scan, target_id) = ({t.scan[row]}, "
                           f"{t.target_id[row]}) then ({t.scan[row + 1]}, {t.target_id[row + 1]}) are not in "
                           f"scan-then-target order or repeat a target's scan")


def check_dataset(dataset: Dataset, detections: str, truth: str) -> None:
    """Raise DatasetError, naming the record, column and row, unless ``dataset``'s values are plausible.

    ``detections`` and ``truth`` name the two records in messages (their
    files, when the dataset was read from disk). Both: columns of one shape
    (N,) and the schema's dtypes, finite floats, scans in 1..n_scans in
    increasing order, times those of `Scenario.scan_schedule` (to
    `TIME_RTOL` x max(1 s, |t|); a report sensor's detections within its
    scan's window (t_k - scan_period_s, t_k], in time order), target ids of the scenario's targets
    (or -1, clutter, in the detections). Detections also: ``is_clutter``
    exactly where ``target_id`` is -1, each row's ``sensor`` the one
    sweeping its scan, ranges > 0 m, azimuths in [0, 2 pi) rad, and (x, y)
    within `POSITION_RTOL` x (|(x, y)| + range) + `POSITION_ATOL_M` m of the
    point at (range, azimuth) from that sensor. Truth also: one row per
    (scan, target), ordered by scan then target.
    """
    scan_time, n_targets, sensors = dataset.scan_time, len(dataset.scenario.targets), dataset.scenario.sensors
    window = None
    if any(s.reports for s in sensors):
        per_sensor = np.array([s.scan_period_s if s.reports else 0.0 for s in sensors])
        sensor = np.clip(np.asarray(dataset.detections.sensor), 0, len(sensors) - 1)  # checked below
        window = per_sensor[sensor]
    _check_record(detections, dataset.detections, DETECTIONS_SCHEMA, scan_time, n_targets, window)
    _check_record(truth, dataset.truth, TRUTH_SCHEMA, scan_time, n_targets)
    _check_detections(detections, dataset)
    _check_truth(truth, dataset)


# ----------------------------------------------------------------------------- reading

def _read_table(path: Path, schema: pa.Schema, record_type):
    if not path.is_file():
        raise DatasetError(f"{path}: missing")
    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError) as exc:
        raise DatasetError(f"{path}: unreadable Parquet file ({exc})") from None
    for f in schema:
        if f.name not in table.column_names:
            raise DatasetError(f"{path}: column {f.name!r} is missing")
        got = table.schema.field(f.name).type
        if got != f.type:
            raise DatasetError(f"{path}: column {f.name!r} has type {got}, expected {f.type}")
    extra = set(table.column_names) - set(schema.names)
    if extra:
        raise DatasetError(f"{path}: unexpected column(s) {sorted(extra)}")
    columns = {}
    for f in schema:
        col = table.column(f.name)
        if col.null_count:
            raise DatasetError(f"{path}: column {f.name!r} has {col.null_count} null value(s)")
        columns[f.name] = col.to_numpy()
    return record_type(**columns)


def _one_radar_at_origin(scenario: Scenario) -> bool:
    if len(scenario.sensors) != 1:
        return False
    s = scenario.sensors[0]
    return s.kind == "polar" and s.position == (0.0, 0.0) and s.full_circle and s.scan_offset_s == 0


def _verify_files(path: Path, meta: dict) -> None:
    """Check the data files against the digests a format-3 manifest records."""
    recorded = meta.get("sha256")
    if (not isinstance(recorded, dict) or sorted(recorded) != sorted(DATA_FILES)
            or not all(isinstance(v, str) for v in recorded.values())):
        raise DatasetError(f"{path / MANIFEST}: field 'sha256' must map {' and '.join(DATA_FILES)} to their "
                           f"SHA-256 digests (format version {meta['format_version']}), got {recorded!r}")
    verify_digests(path, recorded)


def _release(text: object) -> tuple[int, ...] | None:
    """The leading release numbers of an nnda version string ("0.2.0" -> (0, 2, 0)), or None."""
    found = re.match(r"\d+(\.\d+)*", text) if isinstance(text, str) else None
    return tuple(int(n) for n in found.group().split(".")) if found else None


def _check_not_relabelled(where: Path, meta: dict) -> None:
    """A manifest of a format older than the one written now, hence with fewer checks on read, must come from
    an nnda that wrote that format (field 'nnda_version'): a newer dataset relabelled as an old format (its
    digests or seal dropped) would otherwise be read unverified."""
    version = meta["format_version"]
    if version >= FORMAT_VERSION:
        return
    writer = meta.get("nnda_version")
    release = _release(writer)
    if release is None:
        raise DatasetError(f"{where}: field 'nnda_version' is {writer!r}, not an nnda version; a format-{version} "
                           f"manifest names the nnda that wrote it, and this one cannot be verified: regenerate "
                           f"or re-import the dataset")
    later = [v for v, since in sorted(FIRST_WRITER.items()) if v > version and release >= since]
    if later:
        raise DatasetError(f"{where}: field 'format_version' is {version}, but field 'nnda_version' is {writer!r}, "
                           f"which writes format version {later[-1]}: a relabelled (downgraded) manifest, whose "
                           f"checks would be skipped; regenerate or re-import the dataset, or restore its manifest")


def _check_later_fields(where: Path, meta: dict) -> None:
    """A manifest naming format version v holds no field that only a later version writes (an edited one)."""
    version = meta["format_version"]
    for name, since in (("sha256", DIGESTS_SINCE), ("manifest_sha256", SEALED_SINCE),
                        ("geodetic_origin", SEALED_SINCE), ("dropped_rows", SEALED_SINCE),
                        ("time_origin_utc", SEALED_SINCE)):
        if name in meta and version < since:
            raise DatasetError(f"{where}: field {name!r} is written since format version {since}, but field "
                               f"'format_version' is {version}: an edited manifest; regenerate or re-import the "
                               f"dataset")


def _verifymanifest_seal(where: Path, meta: dict) -> None:
    """A format-4 manifest's ``manifest_sha256`` matches its content."""
    if meta.get("manifest_sha256") != manifest_seal(meta):
        raise DatasetError(f"{where}: edited or corrupt (field 'manifest_sha256' does not match the manifest's "
                           f"content); regenerate or re-import the dataset")


def _geodetic_origin(where: Path, meta: dict) -> GeodeticOrigin | None:
    """The manifest's ``geodetic_origin``, checked, or None without one."""
    record = meta.get("geodetic_origin")
    if record is None:
        return None
    keys = ("lat_deg", "lon_deg", "alt_m", "source")
    if (not isinstance(record, dict) or sorted(record) != sorted(keys)
            or not all(isinstance(record[k], (int, float)) and not isinstance(record[k], bool) for k in keys[:3])
            or not isinstance(record["source"], str)):
        raise DatasetError(f"{where}: field 'geodetic_origin' must map lat_deg, lon_deg, alt_m to numbers and "
                           f"source to text, got {record!r}; re-import the dataset")
    try:
        return GeodeticOrigin(**record)
    except ConfigError as exc:
        raise DatasetError(f"{where}: field 'geodetic_origin': {exc}; re-import the dataset") from None


def _dropped_rows(where: Path, meta: dict) -> dict[str, int]:
    """The manifest's ``dropped_rows`` (option -> count), checked; {} without it."""
    record = meta.get("dropped_rows", {})
    if not isinstance(record, dict) or not all(isinstance(k, str) and type(v) is int and v >= 0
                                               for k, v in record.items()):
        raise DatasetError(f"{where}: field 'dropped_rows' must map option names to counts >= 0, got {record!r}; "
                           f"re-import the dataset")
    return dict(record)


def _time_origin_utc(where: Path, meta: dict) -> str | None:
    """The manifest's ``time_origin_utc`` (ISO 8601 text), checked, or None without one."""
    text = meta.get("time_origin_utc")
    if text is not None and not (isinstance(text, str) and _UTC.fullmatch(text)):
        raise DatasetError(f"{where}: field 'time_origin_utc' must be a UTC time such as 2016-01-12T13:02:10Z, got "
                           f"{text!r}; re-import the dataset")
    return text


#: a manifest's ``time_origin_utc``
_UTC = re.compile(r"\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,9})?Z")


def _check_counts(where: Path, meta: dict, dataset: Dataset) -> None:
    """The manifest's summary fields, where present, describe the data read."""
    d, sc = dataset.detections, dataset.scenario
    for key, value in (("n_scans", sc.n_scans), ("n_detections", int(d.scan.size)),
                       ("n_clutter", int(d.is_clutter.sum())), ("target_names", [t.name for t in sc.targets]),
                       ("sensor_names", [s.name for s in sc.sensors])):
        if key in meta and meta[key] != value:
            raise DatasetError(f"{where}: field {key!r} is {meta[key]!r}, but the dataset holds {value!r}")


def read_dataset(path: str | Path) -> Dataset:
    """Read and check one dataset directory (format version 4; 3 without the manifest's seal; 2 and 1, one radar
    at the origin, unverified).

    Refuses, naming the file and field or column and row: a missing or
    foreign manifest, a seed or run that is not a whole number >= 0, an
    invalid scenario, a data file whose SHA-256 differs from the manifest's
    (format 3 on: "corrupt file"), a manifest edited since it was written
    (format 4: its own SHA-256; any format: a field of a later version; an
    older format than its ``nnda_version`` wrote: relabelled), a malformed
    ``geodetic_origin``, ``dropped_rows`` or ``time_origin_utc``, a data file
    that is a symbolic link out of the directory, a Parquet file of another
    schema, and values `check_dataset` refuses.
    """
    path = Path(path)
    if not path.is_dir():
        raise DatasetError(f"{path}: no such dataset directory")
    if not (path / MANIFEST).is_file():
        raise DatasetError(f"{path / MANIFEST}: missing (not an nnda dataset directory?)")
    meta = read_json(path / MANIFEST, FORMAT, READABLE_VERSIONS)
    for key in ("seed", "run", "scenario"):
        if key not in meta:
            raise DatasetError(f"{path / MANIFEST}: field {key!r} is missing")
    seed, run = (whole_number(meta[key], f"{path / MANIFEST}: field {key!r}", error=DatasetError)
                 for key in ("seed", "run"))
    try:
        scenario = scenario_from_dict(meta["scenario"], f"{path / MANIFEST} (field 'scenario')")
    except ConfigError as exc:
        raise DatasetError(str(exc)) from None
    version = meta["format_version"]
    _check_later_fields(path / MANIFEST, meta)
    _check_not_relabelled(path / MANIFEST, meta)
    for name in DATA_FILES:  # fixed names, but a symbolic link could still lead a read elsewhere
        listed_file(path, name, path / MANIFEST, "data file")
    if version == 1 and not _one_radar_at_origin(scenario):
        raise DatasetError(f"{path / MANIFEST}: a format-1 dataset holds one radar at the origin, but field "
                           f"'scenario' describes other sensors")
    if version >= DIGESTS_SINCE:
        _verify_files(path, meta)
    schema = DETECTIONS_SCHEMA_V1 if version == 1 else DETECTIONS_SCHEMA
    detections = _read_table(path / DETECTIONS_FILE, schema, Detections)
    truth = _read_table(path / TRUTH_FILE, TRUTH_SCHEMA, Truth)
    dataset = Dataset(scenario, seed, run, detections, truth, _geodetic_origin(path / MANIFEST, meta),
                      _dropped_rows(path / MANIFEST, meta), _time_origin_utc(path / MANIFEST, meta))
    check_dataset(dataset, str(path / DETECTIONS_FILE), str(path / TRUTH_FILE))
    _check_counts(path / MANIFEST, meta, dataset)
    if version >= SEALED_SINCE:  # last: an edit the checks above name is named so
        _verifymanifest_seal(path / MANIFEST, meta)
    return dataset


def is_collection(path: str | Path) -> bool:
    return (Path(path) / COLLECTION_MANIFEST).is_file()


def collection_members(path: str | Path) -> list[Path]:
    """Member dataset directories of a collection, in manifest order.

    The manifest lists at least one member, each once and each a plain
    directory name (`nnda.files.path_component`); the directory holds
    exactly those members beside the manifest (hidden entries aside).
    DatasetError naming the collection and the members otherwise.
    """
    path = Path(path)
    where = path / COLLECTION_MANIFEST
    meta = read_json(where, COLLECTION_FORMAT, COLLECTION_FORMAT_VERSION)
    members = meta.get("members")
    if not isinstance(members, list) or not all(isinstance(m, str) for m in members):
        raise DatasetError(f"{where}: field 'members' must be a list of names")
    if not members:
        raise DatasetError(f"{where}: field 'members' is empty; a collection holds at least one dataset")
    for m in members:
        try:
            path_component(m, f"{where}: member")
        except ConfigError as exc:
            raise DatasetError(str(exc)) from None
        listed_file(path, m, where, "member")  # and no symbolic link out of the collection
    twice = sorted({m for m, n in Counter(members).items() if n > 1})
    if twice:
        raise DatasetError(f"{where}: field 'members' lists {', '.join(twice)} more than once")
    missing = [m for m in members if not (path / m).is_dir()]
    if missing:
        raise DatasetError(f"{path}: member(s) {_some(missing)} listed in {COLLECTION_MANIFEST} are missing")
    listed = {*members, COLLECTION_MANIFEST}
    extra = sorted(p.name for p in path.iterdir() if p.name not in listed and not p.name.startswith("."))
    if extra:
        raise DatasetError(f"{path}: {_some(extra)} not listed in {COLLECTION_MANIFEST}; a collection holds "
                           f"exactly its members (move the extra entries out, or regenerate the collection)")
    return [path / m for m in members]


def _some(names: list[str], shown: int = 5) -> str:
    """The first ``shown`` names, and how many more."""
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    return ", ".join(names[:shown]) + more


def iter_datasets(path: str | Path) -> Iterator[Dataset]:
    """Datasets stored at ``path``: the dataset itself, or every member of a collection."""
    path = Path(path)
    if is_collection(path):
        for member in collection_members(path):
            yield read_dataset(member)
    else:
        yield read_dataset(path)
