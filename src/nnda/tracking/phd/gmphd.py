"""The Gaussian-mixture PHD recursion (Vo & Ma 2006) as pure functions, batched over components x contacts.

One scan, with J predicted components and N contacts (shapes on the right):

    pred = predict(post, motion, dt, ps)                # survivors: w ps, F m, F P F^T + Q      (J,)
    pred = Mixture.concat([pred, spawn(post, ...), births])  # spawned and newborn components
    pairs = EKF(radar).pairs(pred, z, gate=50.0)        # gated (j, i): innovation, log q_j(z_i)  (P,)
    det, missed = phd_weights(pred.weights, pairs, pd, log_kappa)  # detection (P,), missed (J,)
    post = posterior(pred, pairs, missed, det, prune_above=1e-5)   # missed copies, then per contact

`posterior` builds the J (1 + N) components of Proposition 2 when every
pair is formed (``gate=None``); the chi-square gate leaves out the pairs
whose likelihood is negligible (found without forming them: each
component examines only the contacts in its gate's bounding box, binned in
cells, then the exact distance; the cost grows with the pairs near each
component, not with J x N), and ``prune_above`` drops the light copies
before they are built. The three
linearisations give the same `Pairs`: `Linear` (Cartesian position fixes,
one noise covariance per contact: a radar's contacts converted with their
own covariance), `EKF` and `UKF` (the polar radar measurement through the
EKF's Jacobian or the unscented transform). All the pairs' likelihoods
come from 2 x 2 closed forms; the Kalman correction of the pairs that are
kept is `nnda.filters.kalman.correct` (covariance P - K S K^T, symmetrised);
nothing loops over components or contacts in Python (the binning is one
compiled call, `_box_pairs`).
The CPHD filter (`nnda.tracking.phd.cphd`) reuses all of this and replaces
`phd_weights` only.

Equations are those of Vo & Ma, "The Gaussian mixture probability
hypothesis density filter", IEEE TSP 54(11), 2006: Proposition 1 (prediction
of survivors and spawns) and Proposition 2 (update: missed copies
(1 - p_D) w, detection copies
w_j(z) = p_D w_j q_j(z) / (kappa(z) + p_D sum_l w_l q_l(z))), Table I.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from nnda.data.sensor import TWO_PI
from nnda.filters import kalman, unscented
from nnda.filters.kalman import MeasurementPrediction
from nnda.filters.measurement import MeasurementModel, PolarMeasurement
from nnda.filters.mixture import Mixture
from nnda.filters.motion import POS, MotionModel
from nnda.tracking.clutter_density import MAX_CELLS_PER_AXIS, key_range, sorted_cells


def predict(mixture: Mixture, motion: MotionModel, dt: float, ps: float | np.ndarray,
            transform: unscented.UnscentedTransform | None = None) -> Mixture:
    """Survivors of ``mixture`` after ``dt`` s (Proposition 1): weights ps w (``ps`` a number or one per
    component (J,)), moments predicted by the EKF (``transform`` None) or the unscented transform, same
    labels."""
    if transform is None:
        m, P = kalman.predict(mixture.means, mixture.covariances, motion, dt)
    else:
        m, P = unscented.predict(mixture.means, mixture.covariances, motion, dt, transform)
    return Mixture(ps * mixture.weights, m, P, mixture.labels)


def spawn(mixture: Mixture, motion: MotionModel, dt: float, weight: float, covariance: np.ndarray,
          labels: np.ndarray) -> Mixture:
    """Targets spawned by the components of ``mixture`` over ``dt`` s (Proposition 1, with F_beta = F, d = 0):
    weights ``weight`` w, means F m, covariances F P F^T + Q_beta (``covariance`` (n, n)), new ``labels`` (J,)."""
    m, F = motion.transition(mixture.means, np.asarray(dt, dtype=float))
    return Mixture(weight * mixture.weights, m, kalman.propagate_covariance(F, mixture.covariances, covariance),
                   labels)


@dataclass(frozen=True)
class Pairs:
    """The (predicted component j, contact i) pairs of one update that pass the gate, contact-major.

    ``j``, ``i`` (P,) index the components and contacts (sorted by i, then
    j), ``nu`` (P, 2) holds the innovations z_i - h(m_j) and
    ``log_likelihood`` (P,) log q_j(z_i) = log N(z_i; h(m_j), S_ji);
    ``n_contacts`` is N. ``component`` is the measurement prediction of
    each component (leading shape (J,)) and ``contact_R`` (N, 2, 2), when
    given, the noise of each contact, added to the component's noise-free
    S (then S_ji differs per contact). A pair outside the gate has q = 0.
    """

    j: np.ndarray
    i: np.ndarray
    nu: np.ndarray
    log_likelihood: np.ndarray
    n_contacts: int
    component: MeasurementPrediction
    contact_R: np.ndarray | None = None

    def prediction(self, k: np.ndarray) -> MeasurementPrediction:
        """The measurement predictions of pairs ``k`` (leading shape (K,)), for their correction."""
        j, c = self.j[k], self.component
        if self.contact_R is None:
            return c.take(j)
        return kalman.measurement_prediction(c.z[j], c.S[j] + self.contact_R[self.i[k]], c.H[j], c.PHt[j])


class Contacts(NamedTuple):
    """A scan's contacts as `candidates` bins them: z (N, 2) and the period of their second coordinate (2 pi: an
    azimuth, whose residual is wrapped; 0: none)."""

    z: np.ndarray
    period: float


#: `candidates` widens the second coordinate's windows by this part (and 1e-12 absolute), so that rounding never
#: leaves out a pair the exact gate keeps (the first coordinate's window is the one the gate was always applied in)
_MARGIN = 1e-9


def candidates(contacts: Contacts, centre: np.ndarray, half_width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (j, i) with |z_i0 - centre_j0| <= half_width_j0 and |z_i1 - centre_j1| <= half_width_j1 (the
    second difference wrapped when ``contacts.period``), up to the margin `_MARGIN` on the second: the
    ``contacts`` (N, 2) binned in cells of about the components' median window (`_box_pairs`), each component
    ``centre`` (J, 2) examining only the contacts of the cells its window ``half_width`` (J, 2) overlaps.
    Returns component and contact indices (P,), by contact, then component."""
    z = np.ascontiguousarray(contacts.z, float)
    J, N = len(centre), len(z)
    if not J or not N:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    extent = np.array([np.ptp(z[:, 0]), contacts.period or np.ptp(z[:, 1])])
    cell = np.maximum(np.median(2.0 * half_width, axis=0), extent / (4 * N + 64))
    cell = np.where(np.isfinite(cell) & (cell > 0), cell, 1.0)
    return _box_pairs(z, float(contacts.period), np.ascontiguousarray(centre, float),
                      np.ascontiguousarray(half_width, float), float(cell[0]), float(cell[1]))


@numba.njit(cache=True, nogil=True)
def _box_pairs(z, period, centre, half_width, cell0, cell1):
    """`candidates`' loop. The contacts z (N, 2) go into the cells of `clutter_density.sorted_cells`, the second
    coordinate (taken modulo ``period`` when > 0) scaled by cell0 / cell1 so that one side ``cell0`` serves both
    axes (doubled while an axis would have more than `clutter_density.MAX_CELLS_PER_AXIS`); each component tests
    the contacts of the cells its window [centre - half_width, centre + half_width] overlaps (on a period, its one
    or two runs of rows; the whole period from half a period on): the first coordinate exactly as
    `window_counts`' window, the second's difference (wrapped) against half_width (1 + `_MARGIN`) + 1e-12; the
    pairs found component by component are then ordered by contact (a stable counting sort). Costs O(N log N)
    plus, per component, its cells' bisections and contacts, plus O(N) for the order."""
    N, J = z.shape[0], centre.shape[0]
    k = cell0 / cell1
    pts = np.empty((N, 2))
    for i in range(N):
        pts[i, 0] = z[i, 0]
        pts[i, 1] = (z[i, 1] % period if period > 0 else z[i, 1]) * k
    lo0, hi0, lo1, hi1 = pts[0, 0], pts[0, 0], pts[0, 1], pts[0, 1]
    for i in range(1, N):
        lo0, hi0 = min(lo0, pts[i, 0]), max(hi0, pts[i, 0])
        lo1, hi1 = min(lo1, pts[i, 1]), max(hi1, pts[i, 1])
    if period > 0:
        lo1, hi1 = 0.0, period * k
    cell = cell0
    while max(hi0 - lo0, hi1 - lo1) / cell > MAX_CELLS_PER_AXIS:
        cell *= 2.0
    n0, n1 = int((hi0 - lo0) // cell) + 1, int((hi1 - lo1) // cell) + 1
    order, keys = sorted_cells(pts, lo0, lo1, cell, n1)
    # per component: its columns [runs 0, runs 1] and up to two runs of rows, [runs 2, runs 3] and [runs 4, runs 5]
    # (none: an end below its start)
    runs = np.full((J, 6), -1, np.int64)
    runs[:, 0] = 0
    wide = np.empty(J)
    most = 0
    for j in range(J):
        a, b = centre[j, 0] - half_width[j, 0], centre[j, 0] + half_width[j, 0]
        u0, u1 = (a - lo0) // cell, (b - lo0) // cell  # as `contact_cells`
        w = half_width[j, 1] * (1.0 + _MARGIN) + 1e-12
        wide[j] = w
        if not (u1 >= 0.0 and u0 <= n0 - 1.0 and w >= 0.0):  # also NaN
            continue
        runs[j, 0], runs[j, 1] = int(max(u0, 0.0)), int(min(u1, n0 - 1.0))
        if period > 0 and w >= 0.5 * period:
            runs[j, 2], runs[j, 3] = 0, n1 - 1
        else:
            c = centre[j, 1] % period if period > 0 else centre[j, 1]
            y0, y1 = c - w, c + w
            at_end = period > 0 and y0 < 0.0  # the window's wrapped part: at the period's end, or its start
            if at_end:
                runs[j, 4], runs[j, 5] = int(min((y0 + period) * k // cell, n1 - 1.0)), n1 - 1
                y0 = 0.0
            elif period > 0 and y1 > period:
                runs[j, 4], runs[j, 5] = 0, int(max((y1 - period) * k // cell, 0.0))
                y1 = period
            r0, r1 = (y0 * k - lo1) // cell, (y1 * k - lo1) // cell
            if r1 >= 0.0 and r0 <= n1 - 1.0:
                runs[j, 2], runs[j, 3] = int(max(r0, 0.0)), int(min(r1, n1 - 1.0))
                if at_end:  # a row holding both parts is examined once, in the first run
                    runs[j, 4] = max(runs[j, 4], runs[j, 3] + 1)
                else:
                    runs[j, 5] = min(runs[j, 5], runs[j, 2] - 1)
        for column in range(runs[j, 0], runs[j, 1] + 1):
            for r in (2, 4):
                start, stop = key_range(keys, column, runs[j, r], runs[j, r + 1], n1)
                most += stop - start
    jj = np.empty(most, np.int64)
    ii = np.empty(most, np.int64)
    m = 0
    half = 0.5 * period
    for j in range(J):
        a, b = centre[j, 0] - half_width[j, 0], centre[j, 0] + half_width[j, 0]
        c = centre[j, 1] % period if period > 0 else centre[j, 1]
        for column in range(runs[j, 0], runs[j, 1] + 1):
            for r in (2, 4):
                start, stop = key_range(keys, column, runs[j, r], runs[j, r + 1], n1)
                for t in range(start, stop):
                    i = order[t]
                    if not a <= z[i, 0] <= b:
                        continue
                    d = (pts[i, 1] / k if period > 0 else z[i, 1]) - c
                    if period > 0 and d > half:
                        d -= period
                    elif period > 0 and d < -half:
                        d += period
                    if abs(d) <= wide[j]:
                        jj[m], ii[m] = j, i
                        m += 1
    start = np.zeros(N + 1, np.int64)  # by contact: a counting sort, stable, so by component within a contact
    for p in range(m):
        start[ii[p] + 1] += 1
    for i in range(N):
        start[i + 1] += start[i]
    j_out, i_out = np.empty(m, np.int64), np.empty(m, np.int64)
    for p in range(m):
        q = start[ii[p]]
        j_out[q], i_out[q] = jj[p], ii[p]
        start[ii[p]] += 1
    return j_out, i_out


def window_counts(z0: np.ndarray, centre: np.ndarray, half_width: np.ndarray) -> np.ndarray:
    """How many contacts' first coordinates ``z0`` (N,) lie within ``half_width`` (J,) of each component's
    ``centre`` (J,): (J,), counted without forming the pairs (one sort, two binary searches); a bound on the pairs
    `candidates` forms, whose window on the first coordinate is this one."""
    zs = np.sort(z0)
    lo = np.searchsorted(zs, centre - half_width, "left")
    hi = np.searchsorted(zs, centre + half_width, "right")
    return np.maximum(hi - lo, 0)


def _gated(mp: MeasurementPrediction, z: np.ndarray, gate: float | None, noise: np.ndarray, period: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs (j, i) of components ``mp`` and contacts z (N, 2) for a chi-square ``gate`` (None: all), by
    contact, then component.

    d^2 = nu^T S^-1 nu >= nu_k^2 / S_kk for any positive definite S and
    either coordinate k, so a pair with |nu_k| > sqrt(gate S_kk) is outside
    the gate: a window on each coordinate (range and azimuth, or x and y,
    the gate ellipse's bounding box) prefilters exactly; ``noise`` (2,)
    bounds the contacts' own noise on each (added to the components' S_kk),
    ``period`` is the second coordinate's (`Contacts`).
    """
    J, N = len(mp.z), len(z)
    if gate is None:
        return np.tile(np.arange(J), N), np.repeat(np.arange(N), J)
    half_width = np.column_stack([np.sqrt(gate * (mp.S[:, 0, 0] + noise[0])),
                                  np.sqrt(gate * (mp.S[:, 1, 1] + noise[1]))])
    return candidates(Contacts(z, period), mp.z, half_width)


def _kept(keep, *arrays):
    """The pairs' arrays restricted to ``keep`` (None: all); `_gated`'s order, by contact then component, stays."""
    return arrays if keep is None else tuple(a[keep] for a in arrays)


class Linearisation(ABC):
    """How contacts enter the update: `contacts` maps a scan's measurements to what the pairs are formed
    with, `predict_measurement` linearises the components, `pairs` forms the gated pairs."""

    def __init__(self, measurement: MeasurementModel) -> None:
        self.measurement = measurement

    def contacts(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The measurements the update uses (N, 2) and their own noise (N, 2, 2) or None (the model's R)."""
        return z, None

    @abstractmethod
    def predict_measurement(self, x: np.ndarray, P: np.ndarray) -> MeasurementPrediction:
        """Measurement prediction of states x (J, n), P (J, n, n)."""

    def noise(self, contact_R: np.ndarray | None) -> np.ndarray:
        """The bound on the contacts' own noise on each coordinate (2,) that `pairs` adds to its windows: none
        (the components' S holds the measurement noise)."""
        return np.zeros(2)

    @property
    def period(self) -> float:
        """The period of the second coordinate of what `contacts` returns (2 pi: a polar measurement's azimuth,
        whose residual wraps; else 0)."""
        return TWO_PI if isinstance(self.measurement, PolarMeasurement) else 0.0

    def pair_counts(self, mixture: Mixture, z: np.ndarray, contact_R: np.ndarray | None = None,
                    gate: float | None = None) -> np.ndarray:
        """The candidate pairs `pairs` forms for each component of ``mixture`` (J,) before the exact gate (the
        first coordinate's window; with ``gate`` None, every contact), counted without forming them."""
        if gate is None:
            return np.full(len(mixture), len(z), np.int64)
        mp = self.predict_measurement(mixture.means, mixture.covariances)
        return window_counts(z[:, 0], mp.z[:, 0], np.sqrt(gate * (mp.S[:, 0, 0] + self.noise(contact_R)[0])))

    def pairs(self, mixture: Mixture, z: np.ndarray, contact_R: np.ndarray | None = None,
              gate: float | None = None) -> Pairs:
        """The pairs of the predicted ``mixture`` and the contacts z (N, 2) (from `contacts`) with squared
        Mahalanobis distance <= ``gate`` (None: all J x N pairs)."""
        mp = self.predict_measurement(mixture.means, mixture.covariances)
        j, i = _gated(mp, z, gate, self.noise(None), self.period)
        nu = self.measurement.residual(z[i], mp.z[j])
        d2 = kalman.mahalanobis_2x2(nu, mp.S_inv[j])
        log_det = mp.log_det_S[j]
        j, i, nu, d2, log_det = _kept(None if gate is None else d2 <= gate, j, i, nu, d2, log_det)
        return Pairs(j, i, nu, kalman.gaussian_log_likelihood(d2, log_det), len(z), mp)


class EKF(Linearisation):
    """The measurement model's Jacobian at each component's mean (`nnda.filters.kalman`)."""

    def predict_measurement(self, x, P):
        return kalman.predict_measurement(x, P, self.measurement)


class UKF(Linearisation):
    """The unscented transform of each component (`nnda.filters.unscented`)."""

    def __init__(self, measurement: MeasurementModel, transform: unscented.UnscentedTransform) -> None:
        super().__init__(measurement)
        self.transform = transform

    def predict_measurement(self, x, P):
        return unscented.predict_measurement(x, P, self.measurement, self.transform)


def _position_h(n: int, position: np.ndarray) -> np.ndarray:
    """H (2, n) of a Cartesian position fix: its rows pick the state's x and y (indices ``position``)."""
    H = np.zeros((2, n))
    H[0, position[0]] = H[1, position[1]] = 1.0
    return H


class Linear(Linearisation):
    """Cartesian position fixes, H selecting [x, y], each contact with its own noise R_i.

    `contacts` takes them from the measurement model's ``position``: a
    `PositionMeasurement`'s fixes with its R, or a radar's contacts
    converted to Cartesian with their converted covariance (range- and
    azimuth-dependent), so S_ji = H P_j H^T + R_i. ``position`` (2,) are the
    indices of x and y in the state (the motion model's `position`; default
    the CV layout [x, vx, y, vy]).
    """

    def __init__(self, measurement: MeasurementModel, position: np.ndarray = POS) -> None:
        super().__init__(measurement)
        self.position = np.asarray(position)

    def contacts(self, z):
        return self.measurement.position(z)

    def predict_measurement(self, x, P):
        """The noise-free prediction: z = H x, S = H P H^T (the contacts' noise is added per pair)."""
        at = self.position
        H = _position_h(x.shape[-1], at)
        PHt = np.ascontiguousarray(P[..., at])
        return kalman.measurement_prediction(x[..., at], PHt[..., at, :].copy(),
                                             np.broadcast_to(H, (*x.shape[:-1], *H.shape)), PHt)

    def noise(self, contact_R):
        """The largest of the contacts' own noise variances on x and on y (their R_i, or the model's R): (2,)."""
        if contact_R is None:
            return np.diagonal(self.measurement.R).copy()
        return np.array([contact_R[:, 0, 0].max(initial=0.0), contact_R[:, 1, 1].max(initial=0.0)])

    @property
    def period(self) -> float:
        """0: Cartesian fixes."""
        return 0.0

    def pairs(self, mixture, z, contact_R=None, gate=None):
        if contact_R is None:  # fixes with the model's own noise
            contact_R = np.broadcast_to(self.measurement.R, (len(z), 2, 2))
        mp = self.predict_measurement(mixture.means, mixture.covariances)
        j, i = _gated(mp, z, gate, self.noise(contact_R), self.period)
        nu = z[i] - mp.z[j]
        S_inv, det = kalman.inverse_2x2(mp.S[j] + contact_R[i])
        d2 = kalman.mahalanobis_2x2(nu, S_inv)
        j, i, nu, d2, det = _kept(None if gate is None else d2 <= gate, j, i, nu, d2, det)
        return Pairs(j, i, nu, kalman.gaussian_log_likelihood(d2, np.log(det)), len(z), mp, contact_R)


def per_contact_logsumexp(values: np.ndarray, i: np.ndarray, n: int, floor: np.ndarray) -> np.ndarray:
    """log(exp(floor_c) + sum over the pairs of contact c of exp(values)) for every contact c: (n,).

    ``values`` (P,) belong to contacts ``i`` (P,), sorted; ``floor`` (n,)
    is an extra term per contact (-inf: none). Shifted by each contact's
    maximum, so nothing overflows; a contact whose terms are all -inf gets -inf.
    """
    top = floor.copy()
    if len(i):
        starts = np.flatnonzero(np.r_[True, i[1:] != i[:-1]])
        top[i[starts]] = np.maximum(top[i[starts]], np.maximum.reduceat(values, starts))
    shift = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        total = np.exp(floor - shift) + np.bincount(i, np.exp(values - shift[i]), minlength=n)
        return np.log(total) + shift


def phd_weights(weights: np.ndarray, pairs: Pairs, pd: float | np.ndarray, log_kappa: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """GM-PHD update weights (Proposition 2): of the detection copies, one per pair (P,), and of the
    missed copies (J,).

    ``weights`` (J,) are the predicted weights, ``pd`` the detection
    probability (a number, or one per component (J,)), ``log_kappa`` (N,) the log
    clutter intensity at each contact (-inf: none). Computed in the log
    domain, so a contact that only a far component explains and no clutter
    explains still normalises, and one nothing explains gets no weight.
    """
    with np.errstate(divide="ignore"):
        log_a = np.log(pd * weights)[pairs.j] + pairs.log_likelihood  # log p_D w_j q_j(z_i)
    den = per_contact_logsumexp(log_a, pairs.i, pairs.n_contacts, log_kappa)
    with np.errstate(invalid="ignore"):
        det = np.exp(log_a - den[pairs.i])
    return np.nan_to_num(det, nan=0.0), (1.0 - pd) * weights


def posterior(pred: Mixture, pairs: Pairs, missed: np.ndarray, detected: np.ndarray,
              prune_above: float | None = None) -> Mixture:
    """The updated mixture: J missed copies (``missed`` (J,) weights, predicted moments), then for each
    contact i the detection copies of its pairs (``detected`` (P,) weights, Kalman-corrected moments);
    every copy keeps its component's label. With ``prune_above`` only copies of weight > it are built (the
    same rule as `nnda.filters.mixture.prune`, applied before the corrections are computed)."""
    if prune_above is None:
        keep_missed, k = np.ones(len(missed), bool), np.arange(len(detected))
    else:
        keep_missed, k = missed > prune_above, np.flatnonzero(detected > prune_above)
    j = pairs.j[k]
    m, P = kalman.correct(pred.means[j], pred.covariances[j], pairs.nu[k], pairs.prediction(k))
    return Mixture(np.concatenate([missed[keep_missed], detected[k]]),
                   np.concatenate([pred.means[keep_missed], m]),
                   np.concatenate([pred.covariances[keep_missed], P]),
                   np.concatenate([pred.labels[keep_missed], pred.labels[j]]))
