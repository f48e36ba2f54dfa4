"""Why a tracker lost the hits it lost: each association loss of a run put down to one cause.

    run = ScoredRun(dataset, outputs)            # nnda.study.metrics
    causes = loss_causes(run)                    # {cause: lost target contacts}, summing to run's "losses"
    causes = job_loss_causes(job)                # the same for one tracker job (a TrackJob), run afresh

A *loss* is a target contact the hit rate counts against the tracker (`nnda.study.metrics`: after the
first scan with a track owned by its target, not used by a displayed track of that target). Each one,
of target t in scan k, gets the first cause that applies:

* ``initiation``: no displayed track of t has been confirmed yet (k before the first confirmation):
  initiation delay;
* ``wrong_contact``: a displayed track of t is live in scan k and used another contact (clutter or
  another target's): a wrong association, a track swap;
* ``missed_after_gap``: a displayed track of t is live in scan k and used no contact, and t went
  undetected in some scan since the track's last contact of t: the coasting track failed to pick its
  target up again after a detection gap (life cycle: the prediction, gate and scorer after coasting);
* ``missed_contact``: the same, without a gap since that contact: the track coasted past its target's
  contact, an association the scorer or the gate refused;
* ``gap_deletion``: no track of t is live, and the last one that ended did so at the end of a run of
  scans without a contact of t in which t went undetected at least once (a detection gap, scripted or a
  P_D miss): the life cycle deleted a coasting track and t waits for re-initiation;
* ``break``: no track of t is live, and the last one ended while t was detected in every scan of its
  final run without a contact of t (association misses deleted it), or no track of t has ended (it
  left t for another target): a track break, t waits for re-initiation.

The counts are per run; a study sums or averages them over runs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from threadpoolctl import threadpool_limits

from nnda.study.metrics import ScoredRun
from nnda.tracking.lookup import members, sorted_find
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker

if TYPE_CHECKING:
    from nnda.study.kinds.track import TrackJob

#: the causes, in the order of the module docstring (the first that applies wins)
LOSS_CAUSES: tuple[str, ...] = (
    "initiation", "wrong_contact", "missed_after_gap", "missed_contact", "gap_deletion", "break")
_NEVER = np.iinfo(np.int64).max


def loss_causes(run: ScoredRun) -> dict[str, int]:
    """The run's association losses by cause (`LOSS_CAUSES`, module docstring); the counts sum to the
    ``losses`` measure."""
    det, n_scans = run.dataset.detections, run.dataset.n_scans
    width = n_scans + 2
    rows = run.target_rows[run.counted & ~run.hit_row[run.target_rows]]
    target, scan = det.target_id[rows].astype(np.int64), det.scan[rows].astype(np.int64)

    own = run.displayed & (run.row_owner >= 0)  # reports of displayed tracks owned by a target
    first_conf = np.full(run.n_targets, _NEVER)
    np.minimum.at(first_conf, run.row_owner[own & run.confirmed], run.scan[own & run.confirmed])
    detected = np.zeros((run.n_targets, width), bool)
    detected[det.target_id[run.target_rows], det.scan[run.target_rows]] = True
    undetected = np.cumsum(~detected, axis=1)  # scans each target went undetected, up to and including k

    # each own report: the scan of its track's last contact of its target so far (0: none yet)
    hit = own & run.used & (run.contact_owner == run.row_owner)
    order = np.lexsort((run.scan, run.track))
    base = run.track[order] * width
    since = np.empty_like(run.scan)
    since[order] = np.maximum.accumulate(base + np.where(hit[order], run.scan[order], 0)) - base
    owner = np.maximum(run.row_owner, 0)
    coasting_from_gap = undetected[owner, np.maximum(run.scan - 1, 0)] > undetected[owner, since]

    key = run.row_owner * width + run.scan  # (target, scan) of each report
    live = own & (run.status != TrackStatus.DELETED)
    wrong = live & run.used & (run.contact_owner != run.row_owner)
    loss_key = target * width + scan
    is_live, is_wrong = members(loss_key, key[live]), members(loss_key, key[wrong])
    live_key, live_gap = key[live], coasting_from_gap[live]
    pick = np.argsort(live_key, kind="stable")
    at = sorted_find(live_key[pick], loss_key)[0]
    after_gap_miss = is_live & live_gap[pick][at] if live_key.size else np.zeros(loss_key.size, bool)

    # each ended track: its last report, and whether its final run without a contact of its target
    # (after its last hit, to its end) holds a scan in which the target went undetected
    tracks = np.unique(run.track[own])
    end = np.zeros(run.track_ids.size, np.int64)
    np.maximum.at(end, run.track[own], run.scan[own])
    last_hit = np.zeros(run.track_ids.size, np.int64)
    np.maximum.at(last_hit, run.track[hit], run.scan[hit])
    tracks = tracks[end[tracks] < n_scans]
    t_owner = run.owner[tracks]
    in_gap = undetected[t_owner, end[tracks]] > undetected[t_owner, last_hit[tracks]]
    by_end = np.argsort(t_owner * width + end[tracks], kind="stable")
    end_key, end_gap, end_owner = (t_owner * width + end[tracks])[by_end], in_gap[by_end], t_owner[by_end]
    prev = np.searchsorted(end_key, loss_key, side="right") - 1  # the target's last track ended by then
    found = np.flatnonzero(prev >= 0)
    found = found[end_owner[prev[found]] == target[found]]
    after_gap = np.zeros(loss_key.size, bool)
    after_gap[found] = end_gap[prev[found]]

    cause = np.select([scan < first_conf[target], is_live & is_wrong, after_gap_miss, is_live, after_gap],
                      np.arange(5), default=5)
    counts = np.bincount(cause, minlength=len(LOSS_CAUSES))
    return {name: int(c) for name, c in zip(LOSS_CAUSES, counts)}


def job_loss_causes(job: TrackJob) -> dict[str, int]:
    """`loss_causes` of one study job (a tracker job on a generated run), its tracker run afresh as
    `nnda.study.track_job.run_job` runs it."""
    with threadpool_limits(1):
        dataset = job.dataset()
        tracker = make_tracker(job.kind, dataset.scenario.sensors, job.params)
        outputs = [tracker.step(scan) for scan in dataset.scans()]
        return loss_causes(ScoredRun(dataset, outputs, job.cutoff_m, job.ownership))
