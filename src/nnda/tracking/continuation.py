"""Track continuation: a newly confirmed track that picks up where a coasting confirmed track lost its target.

A target that turns harder than its track's IMM predicted can leave that track's gate. The track coasts, a
new track starts on the target's next contacts and confirms, and the old one is deleted a few scans later:
the target is reported lost and then found again under another id. Associating the two track segments
(Yeom, Kirubarajan & Bar-Shalom 2004) joins them instead: the new track's estimate is tested against each
motion model's own prediction of the old track to the same time, since it is the manoeuvre model, not the
combined prediction, that followed the turn.

The test of a pair (coasting track o, new track n) is, for each model j of o's IMM,

    d^2_j = (x_n - x_oj)^T (P_n + P_oj)^-1 (x_n - x_oj)

on the shared [x, vx, y, vy] (x_n, P_n the new track's estimate after the scan; x_oj, P_oj model j's
prediction of the old track), and the pair's distance is the least d^2_j: a chi-square of 4 dof when
model j is right and the two estimates are independent. Pairs under the gate are matched one to one at the
least total distance (`nnda.tracking.assignment.least_cost_assignment`).
"""

from __future__ import annotations

import numpy as np

from nnda.tracking.assignment import least_cost_assignment


def continuation_pairs(old_x: np.ndarray, old_P: np.ndarray, new_x: np.ndarray, new_P: np.ndarray,
                       allowed: np.ndarray, gate: float) -> tuple[np.ndarray, np.ndarray]:
    """Which new tracks continue which coasting ones (module docstring).

    ``old_x`` (O, r, d) and ``old_P`` (O, r, d, d) are the r models' predictions of O coasting tracks to the
    scan's time, ``new_x`` (N, d) and ``new_P`` (N, d, d) the estimates of N newly confirmed tracks, all on
    the same d state entries (m, m/s); ``allowed`` (O, N) the pairs that may join; ``gate`` the chi-square
    threshold of d dof. Returns the matched (old, new) indices (M,), (M,), sorted by old, each track at most
    once.
    """
    diff = new_x[None, :, None, :] - old_x[:, None, :, :]  # (O, N, r, d)
    S = new_P[None, :, None] + old_P[:, None]  # (O, N, r, d, d)
    d2 = np.einsum("...i,...i->...", diff, np.linalg.solve(S, diff[..., None])[..., 0]).min(axis=2)  # (O, N)
    old, new = np.nonzero(allowed & (d2 < gate))
    if not old.size:
        return old, new
    return least_cost_assignment(old, new, d2[old, new], np.full(old_x.shape[0], gate))
