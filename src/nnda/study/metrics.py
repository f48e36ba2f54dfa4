"""The bookkeeping of one run: who owns each track, and every measure of `nnda.study.measures`.

Ownership comes in two kinds (``ownership`` = "auto", "contacts" or "position"):

* **by contacts**: a track's *owner* is the target that produced the
  majority of the contacts it used (ties go to the lower target id, and a
  target-clutter tie to the target; a track with mostly clutter is owned by
  -1, a false track);
* **by position**: each scan, the confirmed tracks are matched to the true
  targets by `nnda.study.matching` (CLEAR-MOT's rule, threshold = the
  GOSPA cut-off c); a track's owner is the target it was matched to in
  most of its confirmed scans (ties to the lower id), and -1 (false) when
  it went unmatched in more of its confirmed scans than that. A track never
  confirmed has no owner.

"auto" (the study's default) takes contacts when the outputs report any
(a `TrackerOutput.contact` other than NO_CONTACT, or no track at all) and
position otherwise, as for outputs without contacts (PHD filters). The
measures that count contacts (hits, losses, clutter associated, hit rate)
need the outputs' contacts and are undefined (None) without them.

Bookkeeping rules (Vargas Avila (2015)'s measures, read where the thesis is
silent; written down here once).
Only tracks that were confirmed at some scan count as displayed tracks.

* **Hits**: target contacts used by a displayed track of their own target.
  **Association losses**: target contacts after the first scan in which any
  track owned by that target exists, not used by a displayed track of that
  target (so a target's contacts before its track exists, including the
  initiator contact, are not counted). **Clutter associated**: clutter
  contacts used by displayed tracks owned by a target.
  **Hit rate** = 100 hits / (hits + losses + clutter associated)
  (this denominator reproduces all 12 of the thesis's hit rates).
* **Confirmed tracks**: distinct tracks ever confirmed. **False tracks**:
  confirmed tracks owned by -1. **Track breaks**: displayed tracks of a
  target beyond its first. **Lost targets**: targets whose displayed track
  was deleted while the target still produced contacts afterwards.
* **Time to confirm**: per target, from its first contact to the first scan
  in which a displayed track it owns is confirmed (s).
* **Position RMSE**: over scans where a confirmed track owned by the target
  is reported, the track's position estimate against the truth (m).
* **GOSPA** (alpha = 2, p = 2, cut-off c) with its localisation, missed and
  false parts, and **OSPA** (p = 2, the same c) with its localisation and
  cardinality parts (`nnda.study.gospa`), per scan between the true
  positions of the targets present and the confirmed tracks' positions;
  a run's value is the mean over scans. c is the study's
  ``gospa_cutoff_m`` (default `DEFAULT_CUTOFF_M` = 1000 m, the order of this
  radar's gates and initiation window); p = 2 is fixed.
* **Track switches**: per scan, the changes of each target's GOSPA-assigned
  confirmed track since its previous scan (1 from one track to another, 0.5
  between a track and none; counted from the target's first assigned scan,
  `nnda.study.gospa.switching_counts`); a run's value is their sum.
  **GOSPA with switching penalty** gamma: per scan (GOSPA^2 + gamma^2
  switches)^(1/2), the run's value the mean over scans; the registered
  measure takes gamma = c.
* **Target-count error**: per scan |confirmed tracks - targets present|.
* **CLEAR-MOT** from the position matching of every scan (confirmed tracks
  against the targets present, threshold c): MOTA = 1 - (misses + false
  positives + identity switches) / target-scans, MOTP = mean distance of
  the matched pairs (m), identity switches counted as `nnda.study.matching`
  says.

`run_metrics` checks the outputs first: one per scan, in scan order, with
consistent array shapes, finite states, each track once a scan
and contacts inside their scan; a problem raises `ScoringError` naming the
scan and the field.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np

from nnda.data.dataset import Dataset
from nnda.errors import NndaError
from nnda.study.gospa import gospa_assignment, gospa_switching, ospa_parts, switching_counts
from nnda.study.matching import Matches, match_scans
from nnda.study.measures import RUN_MEASURES
from nnda.tracking.output import NO_CONTACT, TrackerOutput, TrackStatus

#: GOSPA/OSPA cut-off distance (m), of the order of the gating region for our geometry; also the
#: distance threshold of the position matching (ownership by position, CLEAR-MOT)
DEFAULT_CUTOFF_M = 1_000.0
Ownership = Literal["auto", "contacts", "position"]
OWNERSHIP: tuple[str, ...] = ("auto", "contacts", "position")
_NEVER = np.iinfo(np.int64).max


class ScoringError(NndaError, ValueError):
    """A tracker's outputs cannot be scored: wrong count or order, inconsistent shapes, non-finite states."""


def _check_outputs(dataset: Dataset, outputs: Sequence[TrackerOutput]) -> None:
    if len(outputs) != dataset.n_scans:
        raise ScoringError(f"expected one output per scan ({dataset.n_scans}), got {len(outputs)}")
    sizes = np.diff(dataset.scan_bounds())
    for k, o in enumerate(outputs, start=1):
        where = f"output {k - 1} (scan {o.scan})"
        if o.scan != k:
            raise ScoringError(f"{where}: expected scan {k}; outputs must come one per scan, in scan order")
        n = np.shape(o.track_id)[0] if np.ndim(o.track_id) == 1 else -1
        shapes = {"track_id": (n,), "status": (n,), "state": (n, 4), "contact": (n,)}
        for field, shape in shapes.items():
            if np.shape(getattr(o, field)) != shape:
                raise ScoringError(f"{where}: {field} has shape {np.shape(getattr(o, field))}, expected {shape} "
                                  f"(track_id has {n} tracks)")
        if np.unique(o.track_id).size != n:
            raise ScoringError(f"{where}: a track id appears more than once")
        bad = ~np.isfinite(np.asarray(o.state, float)).all(axis=1)
        if bad.any():
            raise ScoringError(f"{where}: track {int(o.track_id[np.argmax(bad)])} has a non-finite state")
        meas = np.asarray(o.contact)
        off = (meas != NO_CONTACT) & ((meas < 0) | (meas >= sizes[k - 1]))
        if off.any():
            raise ScoringError(f"{where}: track {int(o.track_id[np.argmax(off)])} names contact {int(meas[off][0])}, "
                              f"but the scan has {int(sizes[k - 1])} contacts (or -1 for none)")


class ScoredRun:
    """A tracker's outputs on a dataset, flattened, with the ownership and the intermediates the
    measures share (each computed once, on first use). Report arrays have one entry per reported
    track per scan, shape (R,), in scan order: ``scan``, ``track`` (index into ``track_ids``),
    ``status``, ``x``/``y`` (m), ``row`` (the detection row used, or -1)."""

    def __init__(self, dataset: Dataset, outputs: Sequence[TrackerOutput], cutoff_m: float = DEFAULT_CUTOFF_M,
                 ownership: Ownership = "auto") -> None:
        if ownership not in OWNERSHIP:
            raise ScoringError(f"ownership must be one of {', '.join(OWNERSHIP)}, got {ownership!r}")
        if not cutoff_m > 0:
            raise ScoringError(f"the cut-off must be > 0 m, got {cutoff_m}")
        _check_outputs(dataset, outputs)
        self.dataset, self.cutoff_m = dataset, float(cutoff_m)
        det = dataset.detections
        self.n_targets = len(dataset.scenario.targets)
        bounds = dataset.scan_bounds()
        self.scan = np.concatenate([np.full(len(o), o.scan) for o in outputs]).astype(np.int64)
        tid = np.concatenate([o.track_id for o in outputs]).astype(np.int64)
        self.status = np.concatenate([o.status for o in outputs]).astype(np.int64)
        state = np.concatenate([o.state for o in outputs]).reshape(-1, 4)
        self.x, self.y = state[:, 0], state[:, 2]
        meas = np.concatenate([o.contact for o in outputs]).astype(np.int64)
        self.row = np.where(meas == NO_CONTACT, -1, bounds[self.scan - 1] + meas)
        self.track_ids, self.track = np.unique(tid, return_inverse=True)
        #: True when the outputs report contacts (or no track at all): the contact measures are defined
        self.has_contacts = bool(self.row.size == 0 or (self.row >= 0).any())
        if ownership == "contacts" and not self.has_contacts:
            raise ScoringError("ownership by contacts: the outputs report no contacts (every contact is NO_CONTACT); "
                              "use ownership 'position' or 'auto'")
        self.ownership = ("contacts" if self.has_contacts else "position") if ownership == "auto" else ownership
        self.used = self.row >= 0
        self.contact_owner = np.where(self.used, det.target_id[np.maximum(self.row, 0)], -2)  # -2: no contact
        self.confirmed = self.status == TrackStatus.CONFIRMED
        self.target_rows = np.flatnonzero(det.target_id >= 0)

    # ------------------------------------------------------------------ ownership

    @cached_property
    def owner(self) -> np.ndarray:
        """Owner of each track (n_tracks,): a target id, or -1 (module docstring)."""
        n = self.track_ids.size
        votes = np.zeros((n, self.n_targets + 1), np.int64)  # column 0: clutter contacts / unmatched scans
        if self.ownership == "contacts":
            np.add.at(votes, (self.track[self.used], self.contact_owner[self.used] + 1), 1)
        else:
            m = self.matches
            np.add.at(votes, (m.track, m.target + 1), 1)
            votes[:, 0] = np.bincount(self.track[self.confirmed], minlength=n) - votes[:, 1:].sum(axis=1)
        target_votes = votes[:, 1:]
        owner = np.argmax(target_votes, axis=1)  # ties -> lower target id
        best = target_votes.max(axis=1)
        owner[(best == 0) | (best < votes[:, 0])] = -1
        return owner

    @cached_property
    def ever_confirmed(self) -> np.ndarray:
        """(n_tracks,) True for tracks confirmed at some scan (the displayed tracks)."""
        out = np.zeros(self.track_ids.size, bool)
        out[self.track[self.confirmed]] = True
        return out

    @cached_property
    def displayed(self) -> np.ndarray:
        """(R,) the report belongs to a displayed track."""
        return self.ever_confirmed[self.track]

    @cached_property
    def row_owner(self) -> np.ndarray:
        """(R,) owner of each report's track."""
        return self.owner[self.track]

    # ------------------------------------------------------------------ contacts

    @cached_property
    def hit_row(self) -> np.ndarray:
        """(n_detections,) True for contacts used by a displayed track of their own target."""
        hit = np.zeros(self.dataset.detections.scan.size, bool)
        good = self.used & self.displayed & (self.row_owner >= 0)
        hit[self.row[good & (self.contact_owner == self.row_owner)]] = True
        return hit

    @cached_property
    def counted(self) -> np.ndarray:
        """(target contacts,) True for target contacts at or after their target's first owned track."""
        det = self.dataset.detections
        first_track_scan = np.full(self.n_targets, _NEVER)
        owned = self.row_owner >= 0
        np.minimum.at(first_track_scan, self.row_owner[owned], self.scan[owned])
        return det.scan[self.target_rows] >= first_track_scan[det.target_id[self.target_rows]]

    @cached_property
    def clutter_rows(self) -> np.ndarray:
        """Distinct clutter contacts used by displayed tracks owned by a target."""
        good = self.used & self.displayed & (self.row_owner >= 0)
        return np.unique(self.row[good & (self.contact_owner == -1)])

    # ------------------------------------------------------------------ positions

    @cached_property
    def truth_xy(self) -> np.ndarray:
        """(M, 2) true positions (m), rows of ``dataset.truth``."""
        return np.column_stack([self.dataset.truth.x, self.dataset.truth.y])

    @cached_property
    def matches(self) -> Matches:
        """The position matching of confirmed tracks to targets, threshold = the cut-off."""
        t, c = self.dataset.truth, self.confirmed
        return match_scans(t.scan.astype(np.int64), t.target_id.astype(np.int64), self.truth_xy, self.scan[c],
                           self.track[c], np.column_stack([self.x[c], self.y[c]]), self.dataset.n_scans,
                           self.n_targets, self.track_ids.size, self.cutoff_m)

    @cached_property
    def counts(self) -> tuple[np.ndarray, np.ndarray]:
        """Per scan (n_scans,) int64: the confirmed tracks reported and the targets present (truth rows)."""
        n = self.dataset.n_scans
        return (np.bincount(self.scan[self.confirmed] - 1, minlength=n),
                np.bincount(self.dataset.truth.scan - 1, minlength=n))

    @cached_property
    def set_distances(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per scan: GOSPA [distance, localisation, missed, false] (n_scans, 4) and OSPA [distance,
        localisation, cardinality] (n_scans, 3); and per truth row (M,) the index into ``track_ids`` of the
        confirmed track GOSPA assigns to it, or -1 (none)."""
        n_scans, truth = self.dataset.n_scans, self.dataset.truth
        g = np.zeros((n_scans, 4))
        o = np.zeros((n_scans, 3))
        assigned = np.full(truth.scan.size, -1, np.int64)
        truth_bounds = np.searchsorted(truth.scan, np.arange(1, n_scans + 2))
        out_bounds = np.searchsorted(self.scan, np.arange(1, n_scans + 2))
        for k in range(n_scans):
            tt = slice(truth_bounds[k], truth_bounds[k + 1])
            oo = slice(out_bounds[k], out_bounds[k + 1])
            conf = self.confirmed[oo]
            est = np.column_stack([self.x[oo][conf], self.y[oo][conf]])
            r, cols = gospa_assignment(self.truth_xy[tt], est, self.cutoff_m)
            g[k] = r.distance, r.localisation, r.missed, r.false
            assigned[tt][cols >= 0] = self.track[oo][conf][cols[cols >= 0]]  # a view of assigned
            q = ospa_parts(self.truth_xy[tt], est, self.cutoff_m)
            o[k] = q.distance, q.localisation, q.cardinality
        return g, o, assigned

    @cached_property
    def switches(self) -> np.ndarray:
        """Per scan (n_scans,) the track switches of the GOSPA assignments (`nnda.study.gospa.switching_counts`:
        1 for a truth passed from one confirmed track to another, 0.5 between a track and none)."""
        truth = self.dataset.truth
        return switching_counts(truth.scan, truth.target_id, self.set_distances[2], self.dataset.n_scans)

    def gospa_switching(self, gamma_m: float) -> np.ndarray:
        """Per scan (n_scans,) GOSPA with switching penalty ``gamma_m`` (m): (GOSPA^2 + gamma^2 switches)^(1/2)
        (p = 2; `nnda.study.gospa.gospa_switching`)."""
        return gospa_switching(self.set_distances[0][:, 0], self.switches, gamma_m)


@dataclass(frozen=True)
class RunMetrics:
    """Every measure of one tracker on one dataset (`nnda.study.measures.MEASURES` but the time).

    ``values[key]`` is a measure's value for the run (a per-scan measure's is its mean over
    scans; None where undefined: the contact measures of outputs without contacts), and
    ``series[key]`` the (n_scans,) array of each per-scan measure. Attribute access reads
    both: ``m.hits`` is ``values["hits"]``, ``m.gospa`` the per-scan array ``series["gospa"]``.
    ``ownership`` is the kind used: "contacts" or "position"; ``counts`` the per-scan (confirmed
    tracks, targets present) of `ScoredRun.counts`.
    """

    values: dict[str, int | float | None]
    series: dict[str, np.ndarray]
    ownership: str
    #: per scan (n_scans,) int64: the confirmed tracks reported and the targets present
    counts: tuple[np.ndarray, np.ndarray] = (np.empty(0, np.int64), np.empty(0, np.int64))

    def __getattr__(self, name: str):
        if name.startswith("__") or name in ("values", "series", "ownership", "counts"):
            raise AttributeError(name)
        if name in self.series:
            return self.series[name]
        if name in self.values:
            return self.values[name]
        raise AttributeError(f"RunMetrics has no measure {name!r}")


def run_metrics(dataset: Dataset, outputs: Sequence[TrackerOutput], cutoff_m: float = DEFAULT_CUTOFF_M,
                ownership: Ownership = "auto") -> RunMetrics:
    """Every measure of a tracker's per-scan ``outputs`` (one per scan, in order) on ``dataset``."""
    return scored_metrics(ScoredRun(dataset, outputs, cutoff_m, ownership))


def scored_metrics(run: ScoredRun) -> RunMetrics:
    """Every measure of a scored run (`run_metrics`), its intermediates kept in ``run`` for further use."""
    values: dict[str, int | float | None] = {}
    series: dict[str, np.ndarray] = {}
    for m in RUN_MEASURES:
        if m.contacts and not run.has_contacts:
            values[m.key] = None
            continue
        value = m.of("track", run)
        if m.per_scan:
            series[m.key] = value
            value = float(value.mean())
        values[m.key] = value
    return RunMetrics(values, series, run.ownership, run.counts)
