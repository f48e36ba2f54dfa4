"""Global nearest neighbour association (baseline).

Each scan, every track's IMM gating prediction (combined state)
is compared with every contact; pairs outside the chi-square gate are
forbidden, and an exact sparse matching finds the one-to-one assignment of
least total cost. The cost of a pair is its squared
Mahalanobis distance plus log |S|, the negative log-likelihood up to a
constant, so a confident track is not out-bid by a vague one; a track may
also stay unassigned at the cost of a contact on its gate's edge. Confirmed
tracks are assigned first and preliminary tracks share what is left, so a
new track cannot take a confirmed target's contact. Problems with more than
``max_exact_pairs`` candidate pairs (thousands of clutter points per scan)
are matched greedily, cheapest pair first, and counted in ``n_greedy``.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

import numba
import numpy as np
from pydantic import Field

from nnda.filters.imm import IMMPrediction
from nnda.filters.kalman import GATE_99
from nnda.tracking.assignment import given, greedy_matching, least_cost_assignment
from nnda.tracking.gating import gate_tracks
from nnda.tracking.output import CONFIRMED, NO_CONTACT
from nnda.tracking.tracker import (
    CLUTTER_ESTIMATE_DOC,
    Association,
    ClutterEstimate,
    ContactTrackerConfig,
    ScanContacts,
    SingleHypothesisTracker,
    TrackerConfig,
    Tracks,
    hard_update,
)


class GNNConfig(ContactTrackerConfig):
    """GNN settings: the chi-square gate (2 dof) and the size up to which assignment is exact."""

    gate: Annotated[float, Field(gt=0, description="chi-square gate, 2 dof (9.21: P_G = 0.99)")] = GATE_99
    max_exact_pairs: Annotated[int, Field(ge=0, description="candidate pairs up to which the assignment "
                                          "is solved exactly; beyond, greedily by cost")] = 20_000
    clutter_estimate: ClutterEstimate = Field("local", description=CLUTTER_ESTIMATE_DOC)


class GNNTracker(SingleHypothesisTracker):
    """IMM tracker with global nearest neighbour association."""

    name: ClassVar[str] = "gnn"
    takes_reports: ClassVar[bool] = True
    config_type: ClassVar[type[TrackerConfig]] = GNNConfig

    def reset(self) -> None:
        super().reset()
        self.n_greedy = 0  # assignments too large to solve exactly (see GNNConfig.max_exact_pairs)

    def associate(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Association:
        imm, z = scan.filter, scan.z
        mp, g = gate_tracks(imm, pred, z, scan.xy, self.config.gate, check=False)
        contact = np.full(len(tracks), NO_CONTACT, np.int64)
        if not g.rows.size:
            return hard_update(imm, pred, z, contact)
        miss_cost = self.config.gate + mp.log_det_S
        for confirmed in (True, False):  # confirmed tracks choose first
            r, c, cost = _stage_pairs(confirmed, tracks.status, g.rows, g.cols, g.d2, mp.log_det_S, contact, len(z))
            if not r.size:
                continue
            if r.size <= self.config.max_exact_pairs:
                rows, cols = least_cost_assignment(r, c, cost, miss_cost)
            else:  # every gated pair costs less than a miss, so greedy takes cheapest first
                rows, cols = greedy_matching(r, c, -cost)
                self.n_greedy += 1
                self._bound_hit("max_exact_pairs", f"{r.size} candidate pairs matched greedily, not exactly",
                                scan.time)
            contact[rows] = cols
        return hard_update(imm, pred, z, contact)


@numba.njit(cache=True, nogil=True)
def _stage_pairs(confirmed, status, rows, cols, d2, log_det, contact, n):
    """One stage of `GNNTracker.associate` in one pass: of the gated pairs (rows, cols, d2 (P,)), those of the
    confirmed tracks (``confirmed``; else the others, by ``status`` (K,)) whose contact no track of ``contact``
    (K,) holds yet among the scan's ``n``, and their costs d2 + log|S| (``log_det`` (K,)): (r, c, cost)."""
    taken = given(contact, n)
    keep = np.empty(rows.size, np.int64)
    m = 0
    for p in range(rows.size):
        if (status[rows[p]] == CONFIRMED) == confirmed and not taken[cols[p]]:
            keep[m] = p
            m += 1
    keep = keep[:m]
    r = rows[keep]
    return r, cols[keep], d2[keep] + log_det[r]
