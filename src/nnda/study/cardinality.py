"""The target count of every scan of every tracker job: estimated, as the filter saw it, and true.

A tracker job records, per scan:

* ``true``: the targets present (rows of the dataset's truth at that scan);
* ``confirmed``: the confirmed tracks the tracker reported (the count every
  tracker estimates, and `nnda.study.measures`' count error compares);
* for trackers that keep a ``cardinality`` record after each ``step`` (the
  PHD family, `nnda.tracking.phd.tracker.Cardinality`, the labelled
  trackers and the Stone Soup GM-PHD peer): ``filter_mean``, the filter's
  own expected count (a PHD: its intensity's total weight; the CPHD: the
  mean of its cardinality distribution; PMBM, GLMB and LMB: the existence
  probabilities summed over their hypotheses), ``filter_map``, the CPHD's
  most probable count, and ``filter_variance``, the variance of the CPHD's
  distribution or of the labelled trackers' count. Each is None
  for the whole run when the tracker does not give it (a PHD has no MAP
  count and no distribution; other trackers have no record), and a scan
  whose record is missing or stale (of another scan) holds None.

The job keeps these under ``cardinality`` in its record (`nnda.study.track_job`,
job format 4) and `nnda.study.track_results` writes them, one row per tracker job
in plan order, to ``cardinality.parquet``: scenario, tracker, kind, run and
the five series as list columns (``true_count`` and ``confirmed_count``
int64; ``filter_mean``, ``filter_variance`` float64 and ``filter_map``
int64, null where the record holds None). `read_cardinality` reads them
back as (runs, scans) arrays for the report.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from nnda.errors import DatasetError
from nnda.files import finite_or_none
from nnda.study.checksums import read_table

CARDINALITY_FILE = "cardinality.parquet"
#: the filter's own series of a job record's ``cardinality``, in record order
FILTER_SERIES = ("filter_mean", "filter_map", "filter_variance")


def snapshot(tracker, scan: int) -> tuple[float | None, int | None, float | None] | None:
    """(mean, MAP count, variance) of the tracker's ``cardinality`` record after stepping scan ``scan``;
    None when it keeps none or its record is of another scan. The variance is that of the record's
    ``distribution`` p(n), n = 0..N_max, or without one its ``variance`` (None when it has neither)."""
    record = getattr(tracker, "cardinality", None)
    if record is None or record.scan != scan:
        return None
    variance = getattr(record, "variance", None)
    if record.distribution is not None:
        p = np.asarray(record.distribution, dtype=float)
        n = np.arange(p.size)
        variance = float((n - n @ p) ** 2 @ p)
    return float(record.mean), None if record.map is None else int(record.map), variance


def count_record(confirmed: np.ndarray, true: np.ndarray, snapshots: list) -> dict:
    """The job record's ``cardinality``: per-scan counts (n_scans,) and the `snapshot` of every scan."""
    out = {"true": [int(v) for v in true], "confirmed": [int(v) for v in confirmed]}
    for i, name in enumerate(FILTER_SERIES):
        values = [None if s is None else s[i] for s in snapshots]
        out[name] = None if all(v is None for v in values) else [
            v if v is None or isinstance(v, int) else finite_or_none(v) for v in values]
    return out


_TYPES = {"true": pa.int64(), "confirmed": pa.int64(), "filter_mean": pa.float64(), "filter_map": pa.int64(),
          "filter_variance": pa.float64()}
#: parquet column of each record series
COLUMNS = {"true": "true_count", "confirmed": "confirmed_count", **{k: k for k in FILTER_SERIES}}


def cardinality_table(records: list[dict]) -> pa.Table:
    """One row per tracker job record (module docstring)."""
    cols = {
        "scenario": pa.array([r["scenario"] for r in records], pa.string()),
        "tracker": pa.array([r["tracker"] for r in records], pa.string()),
        "kind": pa.array([r["kind"] for r in records], pa.string()),
        "run": pa.array([r["run"] for r in records], pa.int32()),
    }
    for key, column in COLUMNS.items():
        cols[column] = pa.array([r["cardinality"][key] for r in records], pa.list_(_TYPES[key]))
    return pa.table(cols)


@dataclass(frozen=True)
class Counts:
    """One tracker's counts on one scenario over its runs: (runs, scans) float arrays, NaN where a run is
    shorter or a value undefined; a ``filter_*`` array is None when no run of the tracker gives it."""

    scenario: str
    tracker: str
    kind: str
    true: np.ndarray
    confirmed: np.ndarray
    filter_mean: np.ndarray | None
    filter_map: np.ndarray | None
    filter_variance: np.ndarray | None

    @property
    def runs(self) -> int:
        return self.true.shape[0]


def _stack(rows: list) -> np.ndarray | None:
    """(runs, max length) float array of per-run lists (None elements and missing tails NaN); None when
    every run's list is None."""
    if all(r is None for r in rows):
        return None
    width = max(len(r) for r in rows if r is not None)
    a = np.full((len(rows), width), np.nan)
    for i, r in enumerate(rows):
        if r is not None:
            a[i, :len(r)] = [np.nan if v is None else v for v in r]
    return a


def read_cardinality(out: str | Path) -> dict[tuple[str, str], Counts]:
    """The counts of a study directory's ``cardinality.parquet`` per (scenario, tracker), in file order.

    DatasetError when the file is missing (a study written before nnda recorded counts, or unfinished)
    or lacks a column."""
    path = Path(out) / CARDINALITY_FILE
    table = read_table(out, CARDINALITY_FILE).to_pydict()
    missing = [c for c in ("scenario", "tracker", "kind", *COLUMNS.values()) if c not in table]
    if missing:
        raise DatasetError(f"{path}: no column {', '.join(missing)}")
    groups: dict[tuple[str, str], list[int]] = {}
    for i, key in enumerate(zip(table["scenario"], table["tracker"])):
        groups.setdefault(key, []).append(i)
    out_: dict[tuple[str, str], Counts] = {}
    for (scenario, tracker), rows in groups.items():
        series = {key: _stack([table[column][i] for i in rows]) for key, column in COLUMNS.items()}
        out_[scenario, tracker] = Counts(scenario, tracker, table["kind"][rows[0]], **series)
    return out_
