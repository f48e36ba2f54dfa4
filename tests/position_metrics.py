"""Position-based scoring of tracker outputs that carry no contacts (the PHD family): each scan's reported
positions assigned to the true ones, a track owned by the target it is assigned to most often."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment


@dataclass(frozen=True)
class PositionScore:
    """``rmse_m`` over assigned (truth, track) pairs; ``missed`` detected truths (a target with a contact in
    that scan) unassigned after each target's first ``warmup`` scans, of ``truths`` such; ``false`` reports
    unassigned, of ``reports``; ``breaks`` owned tracks per target beyond the first (a track is owned by the
    target it is assigned to most often); ``count_error`` mean |reports - truths| per scan."""

    rmse_m: float
    missed: int
    truths: int
    false: int
    reports: int
    breaks: int
    count_error: float


def position_score(dataset, outputs, cutoff_m: float = 500.0, warmup: int = 3, confirmed_only: bool = True
                   ) -> PositionScore:
    """Score ``outputs`` (one `TrackerOutput` per scan) against ``dataset``'s truth: per scan, confirmed tracks
    assigned to true positions (optimal assignment, pairs closer than ``cutoff_m``)."""
    truth = dataset.truth
    first = {int(t): int(truth.scan[truth.target_id == t].min()) for t in np.unique(truth.target_id)}
    err, missed, truths, false, reports, count_err = [], 0, 0, 0, 0, []
    owners: dict[int, Counter] = {}
    for o in outputs:
        sel = truth.scan == o.scan
        P, tid = np.column_stack([truth.x[sel], truth.y[sel]]), truth.target_id[sel]
        keep = o.status == 2 if confirmed_only else np.ones(len(o), bool)
        E, ids = o.state[keep][:, [0, 2]], o.track_id[keep]
        count_err.append(abs(len(E) - len(P)))
        hit = np.zeros(len(P), bool)
        used = np.zeros(len(E), bool)
        if len(P) and len(E):
            d = np.linalg.norm(P[:, None] - E[None], axis=2)
            r, c = linear_sum_assignment(np.minimum(d, cutoff_m))
            ok = d[r, c] < cutoff_m
            r, c = r[ok], c[ok]
            hit[r], used[c] = True, True
            err.extend(d[r, c])
            for a, b in zip(tid[r], ids[c]):
                owners.setdefault(int(b), Counter())[int(a)] += 1
        late = np.array([o.scan >= first[int(t)] + warmup for t in tid], bool) & truth.detected[sel]
        truths += int(late.sum())
        missed += int((late & ~hit).sum())
        false += int((~used).sum())
        reports += len(E)
    per_target = Counter(c.most_common(1)[0][0] for c in owners.values())
    err = np.asarray(err)
    return PositionScore(float(np.sqrt(np.mean(err**2))) if err.size else float("nan"), missed, truths, false,
                         reports, sum(n - 1 for n in per_target.values()), float(np.mean(count_err)))
