"""Asynchronous reports: how a contact tracker takes a window of reports that each carry their own time.

A sensor with ``reports = true`` (AIS, ADS-B, another tracker's plot
stream; `nnda.data.scenario.Sensor`) does not sweep: each report arrives at
its own time, and scan k holds the reports with times in
(t_k - T, t_k], T the sensor's ``scan_period_s`` (`Scan.times`). A tracker
takes such a window in three phases (`Phase`), each one pass of its usual
scan step:

* **reports**: the reports in time order, those that share a time stamp
  together, each group a step at its own time: every track is predicted to
  it, the method associates, a track that takes a report is updated and
  counts a hit. A track no report of the step went to is *not observed*: a
  report of one target says nothing of the others, so no miss is counted
  and no score is lost;
* **due**: at the window's end t_k, without contacts: every track is
  predicted to t_k for the window's output, and a track whose last update
  is older than ``lifecycle.report_gap_s`` is observed and missed, once
  per window, so its life cycle ends it as a swept track's misses would;
* initiation: a report that no track takes waits up to ``report_gap_s`` for
  a later free report of the same sensor inside the speed window for their
  own time difference; the pair starts a preliminary track
  (`TwoPointInitiation.reports`).

The window's output lists every track at t_k; a track's contact is the
window's row of the last report it took (NO_CONTACT if none); a track that a
sanity rule deleted during the window is reported once, DELETED, with its
last estimate.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import Enum

import numpy as np

from nnda.data.dataset import Scan
from nnda.errors import TrackingError
from nnda.tracking.lifecycle import LifecycleConfig, free_window_pairs
from nnda.tracking.lookup import members, sorted_find
from nnda.tracking.output import DELETED, NO_CONTACT, TrackerOutput


class Phase(Enum):
    """Which pass of a scan step a contact tracker is in (module docstring)."""

    SWEEP = "sweep"  # a sensor's sweep: every track in coverage is observed
    REPORTS = "reports"  # asynchronous reports at one time: only the tracks that take one are observed
    DUE = "due"  # a report window's end: the tracks overdue for a report are observed, and miss


def report_times(name: str, scan: Scan, last_time: float, n: int) -> np.ndarray:
    """The report times of ``scan`` (a report sensor's window ending at ``scan.time``, ``n`` contacts) as a
    float (N,) array, checked for tracker ``name``: TrackingError naming the tracker and the scan unless
    there is one finite time per contact, in non-decreasing order, after ``last_time`` (the tracker's last
    step) and at most the window's end."""
    times = getattr(scan, "times", None)
    if times is None:
        raise TrackingError(f"{name}: scan {scan.index} comes from a sensor of asynchronous reports but carries no "
                            f"report times (Scan.times, one per contact)")
    times = np.asarray(times, dtype=float)
    if times.shape != (n,):
        raise TrackingError(f"{name}: scan {scan.index} has {n} report(s) but report times of shape "
                            f"{times.shape}; Scan.times holds one time (s) per contact")
    if n and not (np.isfinite(times).all() and (np.diff(times) >= 0).all()):
        raise TrackingError(f"{name}: scan {scan.index}'s report times must be finite seconds in non-decreasing "
                            f"order")
    end = float(scan.time)
    if not end > last_time or (n and not (times[0] > last_time and times[-1] <= end)):
        shown = f" run {times[0]} to {times[-1]} s" if n else ""
        raise TrackingError(f"{name}: scan {scan.index} ends at t = {scan.time} s and its report times{shown}: "
                            f"a window must end after the previous one (t = {last_time} s), its reports after "
                            f"that and at most at its end")
    return times


def time_groups(times: np.ndarray) -> np.ndarray:
    """Row offsets of the runs of equal ``times`` (N,) sorted: run g is rows [b[g], b[g+1]), shape (G+1,)."""
    cuts = np.flatnonzero(np.diff(times)) + 1
    return np.concatenate([[0], cuts, [times.size]]).astype(np.int64)


def step_window(step: Callable[[Scan, Phase], TrackerOutput], scan: Scan, times: np.ndarray) -> TrackerOutput:
    """One report window (module docstring): ``step(sub_scan, phase)`` once per group of reports at one time
    (`Phase.REPORTS`), then once without contacts at the window's end (`Phase.DUE`); the window's output
    (`merged`)."""
    z = np.asarray(scan.measurements)
    bounds = time_groups(times) if times.size else np.zeros(1, np.int64)
    outputs = [step(Scan(scan.index, float(times[a]), z[a:b], scan.sensor), Phase.REPORTS)
               for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist())]
    end = step(Scan(scan.index, float(scan.time), np.empty((0, 2)), scan.sensor), Phase.DUE)
    return merged(end, outputs, bounds[:-1])


def merged(end: TrackerOutput, outputs: list[TrackerOutput], offsets: np.ndarray) -> TrackerOutput:
    """The window's output: ``end`` (every live track at the window's end, and those its step deleted), each
    track's contact the window's row of the last report it took in ``outputs`` (the report steps', whose
    contacts index the window's rows from ``offsets``), and the tracks those steps deleted, once each."""
    if not outputs:
        return end
    ids = np.concatenate([o.track_id for o in outputs])
    rows = np.concatenate([np.where(o.contact != NO_CONTACT, o.contact + off, NO_CONTACT)
                           for o, off in zip(outputs, offsets.tolist())])
    took = rows != NO_CONTACT
    last_ids, first = np.unique(ids[took][::-1], return_index=True)  # reversed: the last report of each track
    last_rows = rows[took][::-1][first]
    contact = np.full(len(end), NO_CONTACT, np.int64)
    if last_ids.size:
        at, found = sorted_find(last_ids, end.track_id)
        contact[found] = last_rows[at[found]]
    status = np.concatenate([o.status for o in outputs])
    gone = (status == DELETED) & ~members(ids, end.track_id)
    state = np.concatenate([o.state for o in outputs])
    cov = np.concatenate([o.covariance for o in outputs])
    return TrackerOutput.from_blocks(end.scan, end.time, [
        (end.track_id, end.status, end.state, end.covariance, contact),
        (ids[gone], status[gone], state[gone], cov[gone], rows[gone]),
    ])


def report_pairs(initiators: np.ndarray, waited: np.ndarray, contacts: np.ndarray, used: np.ndarray,
                 lifecycle: LifecycleConfig, sigma_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs of waiting reports, ``initiators`` (I, 2) m that waited ``waited`` (I,) s > 0, with the
    ``contacts`` (N, 2) m that no track ``used`` (N,), each inside the speed window of its own wait
    (`LifecycleConfig.window` for that time and the sensor's noise ``sigma_m``): the free contacts' indices
    (F,) ascending and the pairs (i, j) (P,), j indexing them, sorted by initiator. The candidates come from
    the spatial hash of `free_window_pairs` at the longest wait's reach, so the work grows with the reports,
    not with the coverage."""
    if not len(initiators):
        return np.flatnonzero(~np.asarray(used, bool)), np.empty(0, np.int64), np.empty(0, np.int64)
    d_min = np.maximum(0.0, lifecycle.v_min * waited - 3 * sigma_m)
    d_max = lifecycle.v_max * waited + 3 * sigma_m
    free, i, j = free_window_pairs(initiators, contacts, used, 0.0, float(d_max.max()))
    d = np.hypot(*(initiators[i] - contacts[free[j]]).T)
    keep = (d >= d_min[i]) & (d <= d_max[i])
    return free, i[keep], j[keep]
