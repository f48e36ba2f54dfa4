"""How the neural tracker turns a scan's scored pairs into picks: its matching rules, compiled.

A scan's pairs are (track row, contact column, network score in [-1, 1]),
(P,) each. Three rules match them one-to-one (`NeuralConfig.association`):

* ``greedy``: the pairs above the threshold by descending score
  (`greedy_matching`);
* ``global``: the least-cost assignment, a pair costing the negative
  log-odds of its score and a miss the threshold's (`global_matching`);
* ``served``: the assignment serving the most tracks, also through the
  contacts in their IMM gate, then of greatest log-odds (`served_matching`).

Each rule is exact. Where no contact is wanted by two tracks, every rule's
optimum is each track's best pair: `matching` finds it in compiled code and
only a contested scan goes to the sparse solver (`least_cost_assignment`,
scipy), through `solved`.

The tracker's scan runs in three stages, each one compiled pass around that
solver (about 30 numpy calls a scan before):

1. `first_stage`: the pairs the network may take (after a miss, only inside
   the IMM's gate), and the pick of the tracks that choose first (the
   confirmed ones under ``confirmed_first``, else all);
2. `reacquired`: the coasting confirmed tracks left without a contact take
   their nearest free one in the gate (`reacquire`), and the confirmed
   tracks still without one are named for the retrodiction;
3. `rest_stage`: the other tracks' pick among the contacts left; then, with
   a ``preliminary_gate``, `reacquired` again, for the preliminary tracks
   still without a contact.
"""

from __future__ import annotations

import numba
import numpy as np

from nnda.filters.imm_kernels import kernel_array
from nnda.models.scorer import score_log_odds
from nnda.tracking.assignment import given, greedy_kernel, least_cost_assignment
from nnda.tracking.output import CONFIRMED, NO_CONTACT

#: the matching rules' codes in the compiled passes, by `NeuralConfig.association`
RULES = {"greedy": 0, "global": 1, "served": 2}
GREEDY, GLOBAL, SERVED = RULES.values()


def global_matching(rows: np.ndarray, cols: np.ndarray, score: np.ndarray, threshold: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one matching of candidate pairs of least total cost, with a miss option per row.

    ``rows``, ``cols`` (P,) index the pairs' tracks and contacts, ``score``
    (P,) their scores in [-1, 1]. A pair costs -log-odds of its score
    (`score_log_odds`); a row may miss at -log-odds of ``threshold``, so a
    pair scoring at most ``threshold`` is never worth taking. Returns the
    assigned (rows, cols) of `least_cost_assignment`, or, when no contact is
    any other row's candidate too, each row's best pair above ``threshold``
    (the same optimum, found by `greedy_kernel` without the solver).
    """
    return _matched(GLOBAL, rows, cols, score, threshold)


def served_matching(rows: np.ndarray, cols: np.ndarray, score: np.ndarray, threshold: float,
                    gate_rows: np.ndarray, gate_cols: np.ndarray, gate_d2: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one matching that serves the most rows, and of those the one the network likes best.

    ``rows``, ``cols`` (P,) index the network's candidate pairs, ``score`` (P,)
    their scores in [-1, 1]; a pair above ``threshold`` is worth its log-odds
    above the threshold's (`score_log_odds`). ``gate_rows``, ``gate_cols``,
    ``gate_d2`` (Q,) are pairs a row may take on the IMM's word alone (inside
    its gate), worth nothing beyond a tie-break towards the least d² (a pair
    in both lists is worth its score). A row may miss. The matching has the
    most pairs (GNN's aim: each pair is worth more than any sum of log-odds)
    and, among those, the greatest total log-odds, then the least total d²
    of its gate-only pairs. Returns the assigned (rows, cols) of
    `least_cost_assignment`, or, when no contact is in two rows' pairs, each
    row's best pair (`greedy_kernel`: the same optimum without the solver).
    """
    return _matched(SERVED, rows, cols, score, threshold, gate_rows, gate_cols, gate_d2)


def _matched(rule: int, rows: np.ndarray, cols: np.ndarray, score: np.ndarray, threshold: float,
             gate_rows: np.ndarray | None = None, gate_cols: np.ndarray | None = None,
             gate_d2: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """`matching` then `solved`, on arrays of any integer and float type (gate pairs: None for none)."""
    none = np.empty(0, np.int64)
    gate = (none, none, np.empty(0)) if gate_rows is None else (
        np.asarray(gate_rows, np.int64), np.asarray(gate_cols, np.int64), np.asarray(gate_d2, np.float64))
    problem = matching(rule, np.asarray(rows, np.int64), np.asarray(cols, np.int64),
                       np.asarray(score, np.float64), float(threshold), *gate)
    return solved(rule, threshold, *problem)


def solved(rule: int, threshold: float, done: bool, rows: np.ndarray, cols: np.ndarray, worth: np.ndarray,
           tie: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The picks (rows, cols) of a `matching` problem: its own when ``done``, else the sparse solver's
    (`least_cost_assignment`) on its pairs. Under ``served`` a pair costs its tie-break less its worth and
    less a unit that outweighs every sum of worths, and a miss nothing; under ``global`` a pair costs
    -worth and a miss the threshold's negative log-odds."""
    if done:
        return rows, cols
    if rule == SERVED:
        unit = 1.0 + 2.0 * float(worth.sum())  # a pair more outweighs every sum of log-odds
        return least_cost_assignment(rows, cols, tie - worth - unit, np.zeros(int(rows.max()) + 1))
    return least_cost_assignment(rows, cols, -worth, np.full(int(rows.max()) + 1, -score_log_odds(threshold)))


@numba.njit(cache=True, nogil=True)
def matching(rule, rows, cols, score, threshold, gate_rows, gate_cols, gate_d2):
    """The matching problem of ``rule`` (`RULES`) over the pairs (rows, cols, score) (P,) and, under
    ``served``, the gate pairs (gate_rows, gate_cols, gate_d2) (Q,). Returns (done, rows, cols, worth, tie):
    when done, rows and cols are the picks (every rule's optimum when no contact is wanted twice: each
    row's best pair; ``greedy`` always); else the pairs for `solved` with their worth (log-odds; under
    ``served`` above the threshold's) and tie-break (M,)."""
    if rule == SERVED:
        return _served_pairs(rows, cols, score, threshold, gate_rows, gate_cols, gate_d2)
    keep = np.flatnonzero(score > threshold)
    rows, cols, score = rows[keep], cols[keep], score[keep]
    none = np.empty(0)
    if not keep.size:
        return True, rows, cols, none, none
    if rule == GREEDY or not _contested(cols):
        picked_rows, picked_cols = greedy_kernel(rows, cols, score)
        return True, picked_rows, picked_cols, none, none
    worth = np.empty(keep.size)
    for k in range(keep.size):
        worth[k] = score_log_odds(score[k])
    return False, rows, cols, worth, np.zeros(keep.size)


@numba.njit(cache=True, nogil=True)
def _served_pairs(rows, cols, score, threshold, gate_rows, gate_cols, gate_d2):
    """`matching` under ``served``: the network's pairs above ``threshold``, worth their log-odds above its,
    with no tie-break, then the gate pairs not among them, worth 0, with tie-break 1e-6 d²; done (with each
    row's best pair by worth - tie, `greedy_kernel`) when no column occurs twice, or when there is no
    pair."""
    keep = np.flatnonzero(score > threshold)
    n = 1
    for c in cols[keep]:
        n = max(n, c + 1)
    for c in gate_cols:
        n = max(n, c + 1)
    taken = np.sort(rows[keep] * n + cols[keep])
    extra = np.flatnonzero(~among(gate_rows * n + gate_cols, taken))  # a network pair keeps its own worth
    m = keep.size + extra.size
    out_rows, out_cols = np.empty(m, np.int64), np.empty(m, np.int64)
    worth, tie = np.zeros(m), np.zeros(m)
    base = score_log_odds(threshold)
    for k, i in enumerate(keep):
        out_rows[k], out_cols[k], worth[k] = rows[i], cols[i], score_log_odds(score[i]) - base
    for k, i in enumerate(extra):
        j = keep.size + k
        out_rows[j], out_cols[j], tie[j] = gate_rows[i], gate_cols[i], 1e-6 * gate_d2[i]
    if m == 0 or _contested(out_cols):
        return m == 0, out_rows, out_cols, worth, tie
    picked_rows, picked_cols = greedy_kernel(out_rows, out_cols, worth - tie)
    return True, picked_rows, picked_cols, worth, tie


@numba.njit(cache=True, nogil=True)
def _contested(cols):
    """Whether a column occurs twice in ``cols`` (M,) >= 0."""
    n = 0
    for c in cols:
        n = max(n, c + 1)
    wanted = np.zeros(n, np.bool_)
    for c in cols:
        if wanted[c]:
            return True
        wanted[c] = True
    return False


def first_stage(track: np.ndarray, cand: np.ndarray, score: np.ndarray, status: np.ndarray,
                consecutive: np.ndarray, *rest) -> tuple:
    """`_first_stage` with ``consecutive`` (K,) made C-contiguous (the tracker's is a column view of its counts),
    so that the compiled pass has one signature; ``rest`` are `_first_stage`'s other arguments."""
    return _first_stage(track, cand, score, status, kernel_array(consecutive, np.int64), *rest)


def reacquired(contact: np.ndarray, status: np.ndarray, consecutive: np.ndarray, *rest) -> tuple:
    """`_reacquired` with ``consecutive`` (K,) made C-contiguous, as `first_stage`."""
    return _reacquired(contact, status, kernel_array(consecutive, np.int64), *rest)


@numba.njit(cache=True, nogil=True)
def _first_stage(track, cand, score, status, consecutive, n_contacts, gate_after_miss, confirmed_first,
                 coast_after, rule, threshold, gate_rows, gate_cols, gate_d2):
    """The scan's first pick. ``track``, ``cand``, ``score`` (P,) are the network's pairs, ``status``,
    ``consecutive`` (K,) the tracks' status and misses in a row, (gate_rows, gate_cols, gate_d2) (Q,) the
    confirmed tracks' pairs inside the IMM's gate, by row then column.

    With ``gate_after_miss``, a confirmed track that missed its last scan keeps only its pairs inside the
    gate. The tracks that pick first are the confirmed ones under ``confirmed_first``, else all; under
    ``served`` those of them that coast (``coast_after`` misses in a row or more) may also take their gate
    pairs. Returns the pairs kept (track, cand, score), which of them picked first (P',) and that pick's
    `matching` problem."""
    keep = np.ones(track.size, np.bool_)
    if gate_after_miss:
        inside = among(track * n_contacts + cand, gate_rows * n_contacts + gate_cols)
        for p in range(track.size):
            k = track[p]
            keep[p] = inside[p] or not (status[k] == CONFIRMED and consecutive[k] >= 1)
    track, cand, score = track[keep], cand[keep], score[keep]
    first = np.ones(track.size, np.bool_)
    if confirmed_first:
        for p in range(track.size):
            first[p] = status[track[p]] == CONFIRMED
    near = np.zeros(gate_rows.size, np.bool_)
    if rule == SERVED:
        for q in range(gate_rows.size):
            k = gate_rows[q]
            near[q] = status[k] == CONFIRMED and consecutive[k] >= coast_after
    problem = matching(rule, track[first], cand[first], score[first], threshold, gate_rows[near], gate_cols[near],
                       gate_d2[near])
    return track, cand, score, first, problem


@numba.njit(cache=True, nogil=True)
def _reacquired(contact, status, consecutive, which, after, gate_rows, gate_cols, gate_d2, gate, n_contacts):
    """The second stage: ``contact`` (K,) (a new array) with the picks (`reacquire`) of the tracks of status
    ``which`` that have none yet (the confirmed ones: if they coast, ``after`` misses in a row or more),
    among the free ones of the ``n_contacts`` in their gate pairs (gate_rows, gate_cols, gate_d2) (Q,); and
    the confirmed tracks (ascending) that took a contact last scan and are still without one (the
    retrodiction's candidates). With ``which`` PRELIMINARY, the last pick of the scan (``preliminary_gate``)."""
    contact = contact.copy()
    waiting = np.zeros(contact.size, np.bool_)
    for k in range(contact.size):
        waiting[k] = contact[k] == NO_CONTACT and status[k] == which and consecutive[k] >= after
    if waiting.any():
        rows, cols = reacquire(gate_rows, gate_cols, gate_d2, waiting, given(contact, n_contacts), gate)
        contact[rows] = cols
    lost = np.flatnonzero((contact == NO_CONTACT) & (status == CONFIRMED) & (consecutive == 0))
    return contact, lost


@numba.njit(cache=True, nogil=True)
def rest_stage(contact, first, track, cand, score, n_contacts, rule, threshold):
    """The third stage under ``confirmed_first``: the `matching` problem of the pairs (track, cand,
    score) (P,) not among the ``first`` (P,) whose contact no track took in ``contact`` (K,)."""
    taken = given(contact, n_contacts)
    rest = np.zeros(track.size, np.bool_)
    for p in range(track.size):
        rest[p] = not first[p] and not taken[cand[p]]
    none = np.empty(0, np.int64)
    return matching(rule, track[rest], cand[rest], score[rest], threshold, none, none, np.empty(0))


@numba.njit(cache=True, nogil=True)
def reacquire(rows, cols, d2, waiting, taken, gate):
    """Nearest-neighbour picks of the rows still ``waiting`` for a contact, by the IMM's gate.

    ``rows``, ``cols`` (P,) index the candidate pairs' tracks and contacts, ``d2`` (P,) their squared
    Mahalanobis distances; ``waiting`` (K,) flags the tracks that may pick, ``taken`` (N,) the contacts
    already given. Pairs of a waiting row with a free contact and d² <= ``gate`` are matched one-to-one
    by ascending d² (`greedy_kernel`). Returns the (rows, cols) picked (compiled: stage 2 calls it).
    """
    free = np.zeros(rows.size, np.bool_)
    for p in range(rows.size):
        free[p] = waiting[rows[p]] and d2[p] <= gate and not taken[cols[p]]
    if not free.any():
        return rows[free], cols[free]
    return greedy_kernel(rows[free], cols[free], -d2[free])


@numba.njit(cache=True, nogil=True)
def among(keys, sorted_keys):
    """(P,) True for the ``keys`` found in ``sorted_keys`` (ascending), by binary search."""
    if not sorted_keys.size:
        return np.zeros(keys.size, np.bool_)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[pos] == keys
