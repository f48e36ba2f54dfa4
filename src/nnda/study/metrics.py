"""Tracking metrics of one run: the spec's table columns plus standard set metrics.

Bookkeeping rules (spec §9.2 and its default A26, written down here once):

* A track's *owner* is the target that produced the majority of the contacts
  it used (ties go to the lower target id, and a target-clutter tie to the
  target; a track with mostly clutter is owned by -1). Only tracks
  that were confirmed at some scan count as displayed tracks.
* **Hits**: target contacts used by a displayed track of their own target.
  **Association losses**: target contacts after the first scan in which any
  track owned by that target exists, not used by a displayed track of that
  target (so a target's contacts before its track exists, including the
  initiator contact, are not counted). **Clutter associated**: clutter
  contacts used by displayed tracks owned by a target.
  **Hit rate** = 100 hits / (hits + losses + clutter associated) (§9.2).
* **Confirmed tracks**: distinct tracks ever confirmed. **False tracks**:
  confirmed tracks owned by clutter. **Track breaks**: displayed tracks of a
  target beyond its first. **Lost targets**: targets whose displayed track
  was deleted while the target still produced contacts afterwards.
* **Time to confirm**: per target, from its first contact to the first scan
  in which a displayed track it owns is confirmed (s).
* **Position RMSE**: over scans where a confirmed track owned by the target
  is reported, the IMM position estimate against the truth (m).
* **GOSPA** (alpha = 2, p = 2, cut-off c) and **OSPA** per scan between true
  positions of existing targets and confirmed tracks' positions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nnda.data.dataset import Dataset
from nnda.study.gospa import gospa, ospa
from nnda.tracking.output import NO_CONTACT, TrackerOutput, TrackStatus

#: GOSPA/OSPA cut-off distance (m), of the order of the gating region for our geometry
DEFAULT_CUTOFF_M = 1_000.0


@dataclass(frozen=True)
class RunMetrics:
    """Metrics of one tracker on one dataset; per-scan arrays have shape (n_scans,)."""

    target_contacts: int
    hits: int
    losses: int
    clutter_associated: int
    hit_rate: float
    confirmed_tracks: int
    false_tracks: int
    track_breaks: int
    lost_targets: int
    mean_time_to_confirm_s: float
    position_rmse_m: float
    gospa: np.ndarray
    gospa_localisation: np.ndarray
    gospa_missed: np.ndarray
    gospa_false: np.ndarray
    ospa: np.ndarray
    n_false_per_scan: np.ndarray

    def scalars(self) -> dict[str, float]:
        """The run's single-number metrics (per-scan series reduced to their means)."""
        out = {k: getattr(self, k) for k in (
            "target_contacts", "hits", "losses", "clutter_associated", "hit_rate", "confirmed_tracks",
            "false_tracks", "track_breaks", "lost_targets", "mean_time_to_confirm_s", "position_rmse_m")}
        out.update(gospa=float(self.gospa.mean()), ospa=float(self.ospa.mean()))
        return out


def _flatten(outputs: Sequence[TrackerOutput], bounds: np.ndarray):
    """Concatenate the outputs into long arrays: scan, track id, status, x, y, detection row (-1)."""
    scan = np.concatenate([np.full(len(o), o.scan) for o in outputs])
    tid = np.concatenate([o.track_id for o in outputs]).astype(np.int64)
    status = np.concatenate([o.status for o in outputs]).astype(np.int64)
    state = np.concatenate([o.state for o in outputs]).reshape(-1, 4)
    meas = np.concatenate([o.contact for o in outputs]).astype(np.int64)
    row = np.where(meas == NO_CONTACT, -1, bounds[scan - 1] + meas)
    return scan, tid, status, state[:, 0], state[:, 2], row


def run_metrics(dataset: Dataset, outputs: Sequence[TrackerOutput], cutoff_m: float = DEFAULT_CUTOFF_M
                ) -> RunMetrics:
    """Metrics of a tracker's per-scan ``outputs`` (one per scan, in order) on ``dataset``."""
    if len(outputs) != dataset.n_scans:
        raise ValueError(f"expected one output per scan ({dataset.n_scans}), got {len(outputs)}")
    det, truth = dataset.detections, dataset.truth
    n_targets = len(dataset.scenario.targets)
    bounds = dataset.scan_bounds()
    scan, tid, status, x, y, row = _flatten(outputs, bounds)

    used = row >= 0
    contact_owner = np.where(used, det.target_id[np.maximum(row, 0)], -2)  # -2: no contact

    # owner of each track = majority target among its contacts (clutter = -1)
    tracks, tinv = np.unique(tid, return_inverse=True)
    votes = np.zeros((tracks.size, n_targets + 1), np.int64)  # column 0 = clutter
    np.add.at(votes, (tinv[used], contact_owner[used] + 1), 1)
    target_votes = votes[:, 1:]
    owner = np.argmax(target_votes, axis=1)  # ties -> lower target id
    best = target_votes.max(axis=1)
    owner[(best == 0) | (best < votes[:, 0])] = -1
    ever_confirmed = np.zeros(tracks.size, bool)
    ever_confirmed[tinv[status == TrackStatus.CONFIRMED]] = True
    displayed = ever_confirmed[tinv]
    row_owner = owner[tinv]

    # hits, losses, clutter
    target_rows = np.flatnonzero(det.target_id >= 0)
    hit_row = np.zeros(det.scan.size, bool)
    good = used & displayed & (row_owner >= 0)
    hit_row[row[good & (contact_owner == row_owner)]] = True
    first_track_scan = np.full(n_targets, np.iinfo(np.int64).max)
    owned = row_owner >= 0
    np.minimum.at(first_track_scan, row_owner[owned], scan[owned])
    counted = det.scan[target_rows] >= first_track_scan[det.target_id[target_rows]]
    hits = int(hit_row[target_rows].sum())
    losses = int((counted & ~hit_row[target_rows]).sum())
    clutter_rows = np.unique(row[good & (contact_owner == -1)])
    clutter_assoc = int(clutter_rows.size)
    denom = hits + losses + clutter_assoc
    hit_rate = 100.0 * hits / denom if denom else float("nan")

    confirmed_ids = ever_confirmed
    false_tracks = int((confirmed_ids & (owner < 0)).sum())
    per_target = np.bincount(owner[confirmed_ids & (owner >= 0)], minlength=n_targets)
    breaks = int(np.maximum(per_target - 1, 0).sum())

    # lost targets: a displayed track of the target deleted before the target's last contact
    last_contact = np.zeros(n_targets, np.int64)
    np.maximum.at(last_contact, det.target_id[target_rows], det.scan[target_rows])
    deleted = displayed & (status == TrackStatus.DELETED) & (row_owner >= 0)
    lost = np.unique(row_owner[deleted & (scan < last_contact[np.maximum(row_owner, 0)])])

    # time to confirm
    first_contact = np.full(n_targets, np.iinfo(np.int64).max)
    np.minimum.at(first_contact, det.target_id[target_rows], det.scan[target_rows])
    first_conf = np.full(n_targets, np.iinfo(np.int64).max)
    conf_rows = (status == TrackStatus.CONFIRMED) & (row_owner >= 0)
    np.minimum.at(first_conf, row_owner[conf_rows], scan[conf_rows])
    reached = first_conf < np.iinfo(np.int64).max
    period = dataset.scenario.sensor.scan_period_s
    ttc = float(np.mean((first_conf[reached] - first_contact[reached]) * period)) if reached.any() else float("nan")

    # position error of confirmed owned tracks against their target's truth at that scan
    truth_key = truth.scan.astype(np.int64) * (n_targets + 1) + truth.target_id
    est_key = scan[conf_rows] * (n_targets + 1) + row_owner[conf_rows]
    pos = np.searchsorted(truth_key, est_key)
    found = (pos < truth_key.size) & (truth_key[np.minimum(pos, truth_key.size - 1)] == est_key)
    err2 = (x[conf_rows][found] - truth.x[pos[found]]) ** 2 + (y[conf_rows][found] - truth.y[pos[found]]) ** 2
    rmse = float(np.sqrt(err2.mean())) if err2.size else float("nan")

    # set metrics per scan
    n_scans = dataset.n_scans
    g = np.zeros((n_scans, 4))
    o = np.zeros(n_scans)
    nfalse = np.zeros(n_scans, np.int64)
    truth_bounds = np.searchsorted(truth.scan, np.arange(1, n_scans + 2))
    out_bounds = np.searchsorted(scan, np.arange(1, n_scans + 2))
    for k in range(n_scans):
        tt = slice(truth_bounds[k], truth_bounds[k + 1])
        oo = slice(out_bounds[k], out_bounds[k + 1])
        conf = status[oo] == TrackStatus.CONFIRMED
        est = np.column_stack([x[oo][conf], y[oo][conf]])
        tru = np.column_stack([truth.x[tt], truth.y[tt]])
        r = gospa(tru, est, cutoff_m)
        g[k] = r.distance, r.localisation, r.missed, r.false
        o[k] = ospa(tru, est, cutoff_m)
        nfalse[k] = int((owner[tinv[oo]][conf] < 0).sum())

    return RunMetrics(
        target_contacts=int(target_rows.size), hits=hits, losses=losses, clutter_associated=clutter_assoc,
        hit_rate=hit_rate, confirmed_tracks=int(confirmed_ids.sum()), false_tracks=false_tracks,
        track_breaks=breaks, lost_targets=int(lost.size), mean_time_to_confirm_s=ttc, position_rmse_m=rmse,
        gospa=g[:, 0], gospa_localisation=g[:, 1], gospa_missed=g[:, 2], gospa_false=g[:, 3], ospa=o,
        n_false_per_scan=nfalse,
    )
