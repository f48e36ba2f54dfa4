"""A dataset's detections (and truth) written out in the schema ``nnda import-detections`` reads
(`nnda.data.detections_import`), CSV or Parquet: the way back of an import."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from nnda.data.dataset import Dataset
from nnda.data.scenario import Scenario
from nnda.files import atomic_output


def export_detections(dataset: Dataset, path: str | Path, truth: str | Path | None = None) -> None:
    """Write ``dataset``'s detections (and truth) in the import schema, CSV or Parquet by suffix: time, sensor
    (name), range, azimuth (rad), x, y, target_id (the target's name; empty for clutter); with a geodetic
    origin also lat, lon (deg). `read_detections` with the scenario's sensors (`sensor_specs`) reads them back
    into the same scans (x, y taken before lat, lon)."""
    d, sc = dataset.detections, dataset.scenario
    names = np.array([t.name for t in sc.targets], dtype=object)
    labels = np.where(d.target_id < 0, None, names[np.maximum(d.target_id, 0)])
    _write(pa.table({"time": d.time, "sensor": np.array([s.name for s in sc.sensors], dtype=object)[d.sensor],
                     "range": d.range, "azimuth": d.azimuth, "x": d.x, "y": d.y, **_degrees(dataset, d.x, d.y),
                     "target_id": pa.array(labels.tolist(), pa.string())}), Path(path))
    if truth is not None:
        t = dataset.truth
        once = np.sort(np.unique(np.column_stack([t.time, t.target_id]), axis=0, return_index=True)[1])
        _write(pa.table({"time": t.time[once], "target_id": pa.array(names[t.target_id[once]].tolist(), pa.string()),
                         "x": t.x[once], "y": t.y[once], **_degrees(dataset, t.x[once], t.y[once]),
                         "vx": t.vx[once], "vy": t.vy[once]}), Path(truth))


def _degrees(dataset: Dataset, x: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """``lat``, ``lon`` (deg) of points x, y (m) at the height of the dataset's geodetic origin; {} without
    one."""
    if dataset.geodetic_origin is None:
        return {}
    lat, lon = dataset.geodetic_origin.on_surface(x, y)
    return {"lat": lat, "lon": lon}


def sensor_specs(scenario: Scenario) -> list[dict]:
    """The scenario's sensors as `read_detections` takes them (every field but clutter; ``declared_pd`` even
    while None, so the import does not declare their generator's ``pd``)."""
    return [s.model_dump(mode="json", exclude={"clutter"}) | {"declared_pd": s.declared_pd} for s in scenario.sensors]


def _write(table: pa.Table, path: Path) -> None:
    """``table`` at ``path``, CSV or Parquet by suffix, atomically."""
    with atomic_output(path, overwrite=True, directory=False) as tmp:  # a whole file, or none
        if path.suffix.lower() == ".csv":
            pacsv.write_csv(table, tmp)
        else:
            pq.write_table(table, tmp)
