"""Datasets in memory and on disk (conventions.md, "Dataset on disk").

A dataset directory holds ``scenario.json`` (manifest: format, version, seed,
run, the validated scenario with its sensors), ``detections.parquet`` and
``truth.parquet``. A *collection* directory (a Monte Carlo set or a preset
group) holds one dataset directory per member and a ``collection.json``
manifest listing them. Everything is written to a temporary sibling and
renamed into place, so a failed write leaves nothing behind; readers check
format, version and schema and name the file and field they refuse.

Format versions: 2 (written) has a ``sensor`` column in
``detections.parquet``, the index of the detecting sensor in the manifest's
``scenario.sensors``; 1 (one radar at the origin, the scenario in the
one-sensor form) still reads, with that column all 0.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

import nnda
from nnda.data.scenario import Scenario, scenario_from_dict
from nnda.errors import ConfigError, DatasetError
from nnda.files import atomic_directory, dumps, read_json

FORMAT = "nnda.dataset"
COLLECTION_FORMAT = "nnda.collection"
FORMAT_VERSION = 2
#: dataset format versions `read_dataset` reads (1: one radar, no ``sensor`` column)
READABLE_VERSIONS = (1, 2)
COLLECTION_FORMAT_VERSION = 1
MANIFEST = "scenario.json"
COLLECTION_MANIFEST = "collection.json"
DETECTIONS_FILE = "detections.parquet"
TRUTH_FILE = "truth.parquet"


@dataclass(frozen=True)
class Detections:
    """All contacts of a dataset, one entry per detection; arrays of shape (N,).

    Rows are ordered by scan, then by azimuth (the order a rotating antenna
    reports them). ``sensor`` is the index of the detecting sensor in
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
    """

    index: int
    time: float
    measurements: np.ndarray
    sensor: int = 0


@dataclass(frozen=True)
class Dataset:
    """One realisation of a scenario: its config, seed, run index, contacts and truth."""

    scenario: Scenario
    seed: int
    run: int
    detections: Detections
    truth: Truth

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
        """The sweeps in time order, including empty ones, each with its sensor's measurements (see `Scan`)."""
        b = self.scan_bounds()
        d = self.detections
        by_kind = {"polar": np.column_stack([d.range, d.azimuth]), "position": np.column_stack([d.x, d.y])}
        measurements = [by_kind[s.kind] for s in self.scenario.sensors]
        for k, (time, sensor) in enumerate(zip(self.scan_time.tolist(), self.scan_sensor.tolist()), start=1):
            yield Scan(k, time, measurements[sensor][b[k - 1]:b[k]], sensor)


# ----------------------------------------------------------------------------- writing

def _table(record, schema: pa.Schema) -> pa.Table:
    return pa.Table.from_arrays(
        [pa.array(np.asarray(getattr(record, f.name)), type=f.type) for f in schema], schema=schema
    )


def manifest(dataset: Dataset) -> dict:
    """The ``scenario.json`` content: what the dataset is, from what, with what."""
    s = dataset.scenario
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "nnda_version": nnda.__version__,
        "seed": dataset.seed,
        "run": dataset.run,
        "n_scans": s.n_scans,
        "n_detections": int(dataset.detections.scan.size),
        "n_clutter": int(dataset.detections.is_clutter.sum()),
        "target_names": [t.name for t in s.targets],
        "sensor_names": [sensor.name for sensor in s.sensors],
        "scenario": s.model_dump(mode="json"),
    }


def write_dataset_files(dataset: Dataset, directory: Path) -> None:
    """Write the three files of a dataset into an existing, empty ``directory``."""
    (directory / MANIFEST).write_text(dumps(manifest(dataset)))
    pq.write_table(_table(dataset.detections, DETECTIONS_SCHEMA), directory / DETECTIONS_FILE)
    pq.write_table(_table(dataset.truth, TRUTH_SCHEMA), directory / TRUTH_FILE)


def write_dataset(dataset: Dataset, out: str | Path, overwrite: bool = False) -> Path:
    """Write one dataset directory atomically; returns its path."""
    with atomic_directory(out, overwrite) as tmp:
        write_dataset_files(dataset, tmp)
    return Path(out)


def write_collection(
    members: Iterator[tuple[str, Dataset]], out: str | Path, description: str,
    overwrite: bool = False, on_member: Callable[[str], None] | None = None,
) -> Path:
    """Write datasets as sub-directories of one collection, atomically as a whole.

    ``members`` yields (member name, dataset); ``on_member`` is called after
    each member is written (progress reporting).
    """
    names = []
    with atomic_directory(out, overwrite) as tmp:
        for name, dataset in members:
            (tmp / name).mkdir()
            write_dataset_files(dataset, tmp / name)
            names.append(name)
            if on_member is not None:
                on_member(name)
        (tmp / COLLECTION_MANIFEST).write_text(dumps({
            "format": COLLECTION_FORMAT,
            "format_version": COLLECTION_FORMAT_VERSION,
            "nnda_version": nnda.__version__,
            "description": description,
            "members": names,
        }))
    return Path(out)


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
        arr = col.to_numpy()
        if arr.dtype.kind == "f" and not np.isfinite(arr).all():
            bad = int(np.flatnonzero(~np.isfinite(arr))[0])
            raise DatasetError(f"{path}: column {f.name!r} has a non-finite value at row {bad}")
        columns[f.name] = arr
    return record_type(**columns)


def _check_rows(path: Path, scan: np.ndarray, n_scans: int, target_id: np.ndarray, n_targets: int,
                allow_clutter: bool) -> None:
    if scan.size and (scan.min() < 1 or scan.max() > n_scans):
        raise DatasetError(f"{path}: column 'scan' leaves the range 1..{n_scans}")
    if np.any(np.diff(scan) < 0):
        raise DatasetError(f"{path}: column 'scan' is not in increasing order")
    low = -1 if allow_clutter else 0
    if target_id.size and (target_id.min() < low or target_id.max() >= n_targets):
        raise DatasetError(f"{path}: column 'target_id' leaves the range {low}..{n_targets - 1}")


def _check_sensors(path: Path, detections: Detections, scan_sensor: np.ndarray, n_sensors: int) -> None:
    """The ``sensor`` column names sensors of the manifest, each row the one sweeping its scan."""
    sensor = detections.sensor
    if sensor.size and (sensor.min() < 0 or sensor.max() >= n_sensors):
        row = int(np.flatnonzero((sensor < 0) | (sensor >= n_sensors))[0])
        raise DatasetError(f"{path}: column 'sensor' names sensor {sensor[row]} at row {row}, but {MANIFEST} "
                           f"lists {n_sensors} sensor(s) (indices 0..{n_sensors - 1})")
    wrong = sensor != scan_sensor[detections.scan - 1]
    if wrong.any():
        row = int(np.flatnonzero(wrong)[0])
        raise DatasetError(f"{path}: column 'sensor' is {sensor[row]} at row {row}, but scan "
                           f"{detections.scan[row]} is a sweep of sensor {scan_sensor[detections.scan[row] - 1]}")


def _one_radar_at_origin(scenario: Scenario) -> bool:
    if len(scenario.sensors) != 1:
        return False
    s = scenario.sensors[0]
    return s.kind == "polar" and s.position == (0.0, 0.0) and s.full_circle and s.scan_offset_s == 0


def read_dataset(path: str | Path) -> Dataset:
    """Read and validate one dataset directory (format version 2, or 1 as one radar at the origin)."""
    path = Path(path)
    if not path.is_dir():
        raise DatasetError(f"{path}: no such dataset directory")
    if not (path / MANIFEST).is_file():
        raise DatasetError(f"{path / MANIFEST}: missing (not an nnda dataset directory?)")
    meta = read_json(path / MANIFEST, FORMAT, READABLE_VERSIONS)
    for key in ("seed", "run", "scenario"):
        if key not in meta:
            raise DatasetError(f"{path / MANIFEST}: field {key!r} is missing")
    try:
        scenario = scenario_from_dict(meta["scenario"], f"{path / MANIFEST} (field 'scenario')")
    except ConfigError as exc:
        raise DatasetError(str(exc)) from None
    version = meta["format_version"]
    if version == 1 and not _one_radar_at_origin(scenario):
        raise DatasetError(f"{path / MANIFEST}: a format-1 dataset holds one radar at the origin, but field "
                           f"'scenario' describes other sensors")
    schema = DETECTIONS_SCHEMA_V1 if version == 1 else DETECTIONS_SCHEMA
    detections = _read_table(path / DETECTIONS_FILE, schema, Detections)
    truth = _read_table(path / TRUTH_FILE, TRUTH_SCHEMA, Truth)
    n_scans, n_targets = scenario.n_scans, len(scenario.targets)
    _check_rows(path / DETECTIONS_FILE, detections.scan, n_scans, detections.target_id, n_targets, True)
    _check_rows(path / TRUTH_FILE, truth.scan, n_scans, truth.target_id, n_targets, False)
    if not np.array_equal(detections.is_clutter, detections.target_id < 0):
        raise DatasetError(f"{path / DETECTIONS_FILE}: columns 'is_clutter' and 'target_id' disagree")
    dataset = Dataset(scenario, int(meta["seed"]), int(meta["run"]), detections, truth)
    _check_sensors(path / DETECTIONS_FILE, detections, dataset.scan_sensor, len(scenario.sensors))
    return dataset


def is_collection(path: str | Path) -> bool:
    return (Path(path) / COLLECTION_MANIFEST).is_file()


def collection_members(path: str | Path) -> list[Path]:
    """Member dataset directories of a collection, in manifest order."""
    path = Path(path)
    meta = read_json(path / COLLECTION_MANIFEST, COLLECTION_FORMAT, COLLECTION_FORMAT_VERSION)
    members = meta.get("members")
    if not isinstance(members, list) or not all(isinstance(m, str) for m in members):
        raise DatasetError(f"{path / COLLECTION_MANIFEST}: field 'members' must be a list of names")
    return [path / m for m in members]


def iter_datasets(path: str | Path) -> Iterator[Dataset]:
    """Datasets stored at ``path``: the dataset itself, or every member of a collection."""
    path = Path(path)
    if is_collection(path):
        for member in collection_members(path):
            yield read_dataset(member)
    else:
        yield read_dataset(path)
