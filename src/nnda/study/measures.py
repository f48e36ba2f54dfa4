"""The registry of a study's measures: what each one is, how it reads, and the functions that compute it.

One registry for every job kind: a measure names the kinds it applies to
by the functions it has for them (``compute``: kind -> function of that
kind's run), so a measure shared by two kinds (the position RMSE of a
tracker's confirmed tracks and of a single-target filter) is one entry,
and a new measure for several kinds is written in one place. Every table,
summary and figure of the report iterates the registry (`for_kind`, or
picks keys from it) instead of keeping its own labels and units, and the
tracker jobs' records, ``results.parquet`` and ``summary.json`` hold one
value per `RUN_MEASURES` key (the filter jobs' per `FILTER_MEASURES` key).
A `Measure` has:

* ``key``: its name in job records, ``results.parquet`` and ``summary.json``;
* ``label`` and ``unit``: how a table names it (``title`` = "label (unit)");
  ``fmt`` and ``scale``: how a value reads (``fmt.format(value * scale)``, in
  ``unit``);
* ``better``: "higher", "lower" or "none" (a property of the data or the
  tracker's size, not of its quality);
* ``bounds``: its possible range (low, high), which cuts confidence
  intervals over runs;
* ``per_scan``: True for a per-scan series whose run value is its mean
  over scans (the series is kept as well, under ``series_name``), False
  for a value of the whole run;
* ``compute``: per job kind, the function that gives the value (the
  (n_scans,) array of a per-scan measure): of a `nnda.study.metrics.ScoredRun`
  for "track", of a `nnda.study.filter_run.FilterRun` for "filter"; empty for the time per scan,
  which a job measures around each step and keeps in ``timing.json``
  (wall-clock time changes between two runs of a study), the kinds it
  times in ``timed``;
* ``integer``: a count (int64: the value of a per-run measure, the series
  of a per-scan one); ``contacts``: the value needs the outputs' contacts
  (None for outputs without them).

The bookkeeping the tracker functions share (ownership, the position
matching) is `nnda.study.metrics`'s; its module docstring states the rules.
A filter job's run is scored by `nnda.study.filter_run`'s functions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from nnda.study import filter_run
from nnda.study.stats import mean_ci, root_mean_square
from nnda.tracking.output import TrackStatus

if TYPE_CHECKING:
    from nnda.study.metrics import ScoredRun

Better = Literal["higher", "lower", "none"]
#: the job kinds whose runs the registry's functions score (`nnda.study.kinds`)
TRACK, FILTER = "track", "filter"
_NEVER = np.iinfo(np.int64).max
_COUNT = (0.0, math.inf)


@dataclass(frozen=True)
class Measure:
    """One measure of the registry (module docstring)."""

    key: str
    label: str
    unit: str
    better: Better
    bounds: tuple[float, float]
    per_scan: bool
    compute: Mapping[str, Callable[[Any], Any]]
    fmt: str = "{:.2f}"
    scale: float = 1.0
    integer: bool = False
    contacts: bool = False
    series: str = ""
    timed: tuple[str, ...] = ()

    @property
    def kinds(self) -> tuple[str, ...]:
        """The job kinds this measure applies to: those it has a function for, or that time it."""
        return tuple(self.compute) or self.timed

    def of(self, kind: str, run: Any) -> Any:
        """The measure of ``run``, the input of job kind ``kind`` (`ScoredRun` for "track", `FilterRun` for
        "filter")."""
        return self.compute[kind](run)

    @property
    def title(self) -> str:
        """The row or column name of a table: label, ", mean over scans" for a per-scan measure, unit."""
        text = self.label + (", mean over scans" if self.per_scan else "")
        return f"{text} ({self.unit})" if self.unit else text

    @property
    def sense(self) -> int:
        """+1 when higher is better, -1 when lower is, 0 when neither."""
        return {"higher": 1, "lower": -1, "none": 0}[self.better]

    @property
    def series_name(self) -> str:
        """Name of a per-scan measure's series in job records (``results.parquet``: ``<name>_per_scan``)."""
        return self.series or self.key

    @property
    def timing(self) -> bool:
        """True for the wall-clock measure kept in ``timing.json`` rather than with the metrics."""
        return not self.compute


# ----------------------------------------------------------------------------- contacts

def _target_contacts(r: ScoredRun) -> int:
    return int(r.target_rows.size)


def _hits(r: ScoredRun) -> int:
    return int(r.hit_row[r.target_rows].sum())


def _losses(r: ScoredRun) -> int:
    return int((r.counted & ~r.hit_row[r.target_rows]).sum())


def _clutter_associated(r: ScoredRun) -> int:
    return int(r.clutter_rows.size)


def _hit_rate(r: ScoredRun) -> float:
    hits = _hits(r)
    denom = hits + _losses(r) + _clutter_associated(r)
    return 100.0 * hits / denom if denom else float("nan")


# ----------------------------------------------------------------------------- tracks

def _confirmed_tracks(r: ScoredRun) -> int:
    return int(r.ever_confirmed.sum())


def _false_tracks(r: ScoredRun) -> int:
    return int((r.ever_confirmed & (r.owner < 0)).sum())


def _track_breaks(r: ScoredRun) -> int:
    per_target = np.bincount(r.owner[r.ever_confirmed & (r.owner >= 0)], minlength=r.n_targets)
    return int(np.maximum(per_target - 1, 0).sum())


def _lost_targets(r: ScoredRun) -> int:
    """Targets whose displayed track was deleted before the target's last contact."""
    det = r.dataset.detections
    last_contact = np.zeros(r.n_targets, np.int64)
    np.maximum.at(last_contact, det.target_id[r.target_rows], det.scan[r.target_rows])
    deleted = r.displayed & (r.status == TrackStatus.DELETED) & (r.row_owner >= 0)
    return int(np.unique(r.row_owner[deleted & (r.scan < last_contact[np.maximum(r.row_owner, 0)])]).size)


def _owned_confirmed(r: ScoredRun) -> np.ndarray:
    return r.confirmed & (r.row_owner >= 0)


def _time_to_confirm(r: ScoredRun) -> float:
    det = r.dataset.detections
    first_contact = np.full(r.n_targets, _NEVER)
    np.minimum.at(first_contact, det.target_id[r.target_rows], det.scan[r.target_rows])
    first_conf = np.full(r.n_targets, _NEVER)
    rows = _owned_confirmed(r)
    np.minimum.at(first_conf, r.row_owner[rows], r.scan[rows])
    reached = first_conf < _NEVER
    if not reached.any():
        return float("nan")
    time = r.dataset.scan_time  # of scan k at k - 1
    return float(np.mean(time[first_conf[reached] - 1] - time[first_contact[reached] - 1]))


def _position_rmse(r: ScoredRun) -> float:
    """Confirmed owned tracks' positions against their target's truth at the same scan (m)."""
    truth, n = r.dataset.truth, r.n_targets
    rows = _owned_confirmed(r)
    truth_key = truth.scan.astype(np.int64) * (n + 1) + truth.target_id
    est_key = r.scan[rows] * (n + 1) + r.row_owner[rows]
    pos = np.searchsorted(truth_key, est_key)
    found = (pos < truth_key.size) & (truth_key[np.minimum(pos, truth_key.size - 1)] == est_key)
    err2 = (r.x[rows][found] - truth.x[pos[found]]) ** 2 + (r.y[rows][found] - truth.y[pos[found]]) ** 2
    return float(root_mean_square(err2))


# ----------------------------------------------------------------------------- per scan

def _set_part(metric: int, i: int) -> Callable[[ScoredRun], np.ndarray]:
    """Column i of `ScoredRun.set_distances`'s metric 0 (GOSPA: distance, localisation, missed, false)
    or 1 (OSPA: distance, localisation, cardinality)."""
    return lambda r: r.set_distances[metric][:, i]


def _gospa_switching(r: ScoredRun) -> np.ndarray:
    """(n_scans,) GOSPA with switching penalty gamma = the run's cut-off c (m)."""
    return r.gospa_switching(r.cutoff_m)


def _count_error(r: ScoredRun) -> np.ndarray:
    """(n_scans,) |confirmed tracks reported - targets present| in each scan: how well the tracker counts."""
    reported, present = r.counts
    return np.abs(reported - present).astype(float)


#: scans in a row whose confirmed-track count must equal the number of targets present for the count to be
#: settled (`_time_to_count`)
SETTLED_SCANS = 5


def _time_to_count(r: ScoredRun) -> float:
    """Seconds from the first scan to the first of ``SETTLED_SCANS`` scans in a row whose confirmed-track count
    equals the number of targets present (NaN if that never happens)."""
    reported, present = r.counts
    ok = (reported == present).astype(np.int64)
    if ok.size < SETTLED_SCANS:
        return float("nan")
    settled = np.flatnonzero(np.convolve(ok, np.ones(SETTLED_SCANS, np.int64), "valid") == SETTLED_SCANS)
    time = r.dataset.scan_time
    return float(time[settled[0]] - time[0]) if settled.size else float("nan")


def _tracked_undetected(r: ScoredRun) -> float:
    """% of the target-scans without a detection (a miss, a gap, occlusion, outside the coverage) in which a
    confirmed track is matched to the target (the CLEAR-MOT matching); NaN when every target-scan has one."""
    t, m = r.dataset.truth, r.matches
    gap = ~t.detected
    if not gap.any():
        return float("nan")
    n = r.n_targets + 1
    matched = np.isin(t.scan[gap].astype(np.int64) * n + t.target_id[gap], m.scan * n + m.target)
    return 100.0 * float(matched.mean())


def _false_per_scan(r: ScoredRun) -> np.ndarray:
    """(n_scans,) confirmed tracks owned by -1 in each scan (int64)."""
    return np.bincount(r.scan[r.confirmed & (r.row_owner < 0)] - 1, minlength=r.dataset.n_scans).astype(np.int64)


# ----------------------------------------------------------------------------- CLEAR-MOT

def _mota(r: ScoredRun) -> float:
    """1 - (misses + false positives + identity switches) / target-scans (Bernardin & Stiefelhagen eq. 2)."""
    m, n_truth = r.matches, int(r.dataset.truth.scan.size)
    if n_truth == 0:
        return float("nan")
    misses, false_positives = n_truth - m.scan.size, int(r.confirmed.sum()) - m.scan.size
    return 1.0 - (misses + false_positives + int(m.switch.sum())) / n_truth


def _motp(r: ScoredRun) -> float:
    """Mean distance (m) of the matched (target, track) pairs over all scans (eq. 1)."""
    d = r.matches.distance
    return float(d.sum() / d.size) if d.size else float("nan")


def _id_switches(r: ScoredRun) -> int:
    return int(r.matches.switch.sum())


def _track_switches(r: ScoredRun) -> float:
    """The run's track switches of the GOSPA assignments: 1 for each change from one track to another, 0.5
    between a track and none (`nnda.study.gospa.switching_counts`)."""
    return float(r.switches.sum())


# ----------------------------------------------------------------------------- the registry

#: the possible range of the per-run quantities kept outside the registry (the pedestrian study's per-run measures,
#: its runtime per run and its estimate counts per run): a report cuts their intervals to it
#: (`nnda.study.stats.clip_interval`); a key absent here (a bias) may take either sign
PER_RUN_BOUNDS: dict[str, tuple[float, float]] = {
    "ospa": _COUNT, "gospa": _COUNT, "count_error": _COUNT, "time_per_scan_s": _COUNT, "runtime_s": _COUNT,
    "missed": (0.0, 1.0), "duplicates": _COUNT, "estimates_per_point": _COUNT}

#: every measure, in the order of the report's per-scenario tables (the thesis's seven rows first)
MEASURES: tuple[Measure, ...] = (
    Measure("target_contacts", "Target contacts", "", "none", _COUNT, False, {TRACK: _target_contacts}, "{:.1f}",
            integer=True),
    Measure("hits", "Hits", "", "higher", _COUNT, False, {TRACK: _hits}, "{:.1f}", integer=True, contacts=True),
    Measure("losses", "Association losses", "", "lower", _COUNT, False, {TRACK: _losses}, "{:.1f}", integer=True,
            contacts=True),
    Measure("clutter_associated", "Clutter associated with tracks", "", "lower", _COUNT, False,
            {TRACK: _clutter_associated}, integer=True, contacts=True),
    Measure("hit_rate", "Hit rate", "%", "higher", (0.0, 100.0), False, {TRACK: _hit_rate}, contacts=True),
    Measure("mean_time_per_scan_s", "Time per scan", "ms", "lower", _COUNT, True, {}, "{:.4g}", 1e3,
            timed=(TRACK, FILTER)),
    Measure("confirmed_tracks", "Confirmed tracks", "", "none", _COUNT, False, {TRACK: _confirmed_tracks},
            integer=True),
    Measure("false_tracks", "False tracks", "", "lower", _COUNT, False, {TRACK: _false_tracks}, integer=True),
    Measure("track_breaks", "Track breaks", "", "lower", _COUNT, False, {TRACK: _track_breaks}, integer=True),
    Measure("lost_targets", "Lost targets", "", "lower", _COUNT, False, {TRACK: _lost_targets}, integer=True),
    Measure("mean_time_to_confirm_s", "Time to confirm", "s", "lower", _COUNT, False, {TRACK: _time_to_confirm},
            "{:.1f}"),
    Measure("position_error_m", "Position error", "m", "lower", _COUNT, True, {FILTER: filter_run.position_error},
            "{:.1f}"),
    Measure("position_rmse_m", "Position RMSE", "m", "lower", _COUNT, False,
            {TRACK: _position_rmse, FILTER: filter_run.rmse((0, 2))}, "{:.1f}"),
    Measure("velocity_rmse_m_s", "Velocity RMSE", "m/s", "lower", _COUNT, False, {FILTER: filter_run.rmse((1, 3))},
            "{:.1f}"),
    Measure("nees", "NEES (4 when consistent)", "", "none", _COUNT, True, {FILTER: filter_run.FilterRun.nees},
            "{:.2f}"),
    Measure("divergence_pct", "Divergent scans (NEES > 18.47)", "%", "lower", (0.0, 100.0), False,
            {FILTER: filter_run.divergence}),
    Measure("start_s", "Time to the first estimate", "s", "lower", _COUNT, False, {FILTER: filter_run.start}, "{:.1f}"),
    Measure("gospa", "GOSPA", "m", "lower", _COUNT, True, {TRACK: _set_part(0, 0)}, "{:.1f}"),
    Measure("gospa_localisation", "GOSPA localisation part", "m²", "lower", _COUNT, True, {TRACK: _set_part(0, 1)},
            "{:,.0f}"),
    Measure("gospa_missed", "GOSPA missed-target part", "m²", "lower", _COUNT, True, {TRACK: _set_part(0, 2)},
            "{:,.0f}"),
    Measure("gospa_false", "GOSPA false-track part", "m²", "lower", _COUNT, True, {TRACK: _set_part(0, 3)},
            "{:,.0f}"),
    Measure("gospa_switching", "GOSPA with switching penalty c", "m", "lower", _COUNT, True,
            {TRACK: _gospa_switching}, "{:.1f}"),
    Measure("ospa", "OSPA", "m", "lower", _COUNT, True, {TRACK: _set_part(1, 0)}, "{:.1f}"),
    Measure("ospa_localisation", "OSPA localisation part", "m", "lower", _COUNT, True, {TRACK: _set_part(1, 1)},
            "{:.1f}"),
    Measure("ospa_cardinality", "OSPA cardinality part", "m", "lower", _COUNT, True, {TRACK: _set_part(1, 2)},
            "{:.1f}"),
    Measure("count_error", "Target-count error (confirmed tracks vs targets)", "", "lower", _COUNT, True,
            {TRACK: _count_error}, "{:.2f}"),
    # its series is "false_tracks" in job records (results.parquet: false_tracks_per_scan, see nnda.study.track_results)
    Measure("false_tracks_per_scan", "False tracks present", "", "lower", _COUNT, True, {TRACK: _false_per_scan},
            "{:.3f}", integer=True, series="false_tracks"),
    Measure("time_to_count_s", "Time to a correct count", "s", "lower", _COUNT, False, {TRACK: _time_to_count},
            "{:.1f}"),
    Measure("tracked_undetected", "Targets tracked while undetected", "%", "higher", (0.0, 100.0), False,
            {TRACK: _tracked_undetected}, "{:.1f}"),
    Measure("mota", "MOTA", "", "higher", (-math.inf, 1.0), False, {TRACK: _mota}, "{:.3f}"),
    Measure("motp_m", "MOTP", "m", "lower", _COUNT, False, {TRACK: _motp}, "{:.1f}"),
    Measure("id_switches", "Identity switches", "", "lower", _COUNT, False, {TRACK: _id_switches}, integer=True),
    Measure("track_switches", "Track switches (GOSPA assignment)", "", "lower", _COUNT, False, {TRACK: _track_switches},
            "{:.1f}"),
)


def for_kind(kind: str) -> tuple[Measure, ...]:
    """The measures that apply to job kind ``kind``, in registry order."""
    return tuple(m for m in MEASURES if kind in m.kinds)


#: the tracker measures (the per-scenario tables' rows, the wall-clock time among them), in registry order
TRACK_MEASURES = for_kind(TRACK)
#: the tracker measures computed from a run's outputs (all but the wall-clock time)
RUN_MEASURES: tuple[Measure, ...] = tuple(m for m in TRACK_MEASURES if not m.timing)
#: the run measures kept as per-scan series too
SERIES_MEASURES: tuple[Measure, ...] = tuple(m for m in RUN_MEASURES if m.per_scan)
#: the measures of a filter job, in the order of the report's filter tables
FILTER_MEASURES: tuple[Measure, ...] = tuple(m for m in for_kind(FILTER) if not m.timing)
#: the filter measures kept as per-scan series too
FILTER_SERIES: tuple[Measure, ...] = tuple(m for m in FILTER_MEASURES if m.per_scan)
_BY_KEY = {m.key: m for m in MEASURES}
#: the time per scan (s): the job's wall-clock measure
TIME: Measure = next(m for m in MEASURES if m.timing)


def time_summary(per_run: Sequence[Sequence[float]], confidence: float) -> dict:
    """The time per scan (or step) of one estimator over its runs, each run a list of seconds: the mean over runs
    of each run's mean with its t-interval (under `TIME`'s key), and the median, 95th percentile and maximum
    of every scan of every run (s)."""
    every = np.concatenate([np.asarray(t, dtype=float) for t in per_run])
    return {TIME.key: mean_ci([float(np.mean(t)) for t in per_run], confidence, *TIME.bounds),
            "median_s": float(np.median(every)), "p95_s": float(np.percentile(every, 95)), "max_s": float(every.max())}


def measure(key: str) -> Measure:
    """The registered measure ``key``; KeyError naming the registered keys otherwise."""
    try:
        return _BY_KEY[key]
    except KeyError:
        raise KeyError(f"no measure {key!r}; registered: {', '.join(_BY_KEY)}") from None
