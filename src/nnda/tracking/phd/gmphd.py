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

import numpy as np

from nnda.data.sensor import TWO_PI
from nnda.filters import kalman, unscented
from nnda.filters.kalman import MeasurementPrediction
from nnda.filters.measurement import MeasurementModel, PolarMeasurement
from nnda.filters.mixture import Mixture
from nnda.filters.motion import POS, MotionModel
from nnda.tracking.box_pairs import Contacts, candidates
from nnda.tracking.lookup import run_starts
from nnda.tracking.phd import gate_kernels


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


def _float(a: np.ndarray) -> np.ndarray:
    """``a`` as a C-contiguous float64 array, as the compiled gate takes it (a copy only where needed)."""
    return np.ascontiguousarray(a, np.float64)


def _limit(gate: float | None) -> tuple[float, bool]:
    """The compiled gate's threshold and whether it keeps every pair (``gate`` None)."""
    return (np.inf, True) if gate is None else (float(gate), False)


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

    def prediction(self, mixture: Mixture) -> MeasurementPrediction:
        """The measurement prediction of the components of ``mixture`` (leading shape (J,)), as `pairs` forms it."""
        return self.predict_measurement(mixture.means, mixture.covariances)

    def pair_counts(self, mp: MeasurementPrediction, z: np.ndarray, contact_R: np.ndarray | None = None,
                    gate: float | None = None) -> np.ndarray:
        """The candidate pairs `pairs` forms for each component of measurement prediction ``mp`` (`prediction`,
        (J,)) before the exact gate (the first coordinate's window; with ``gate`` None, every contact), counted
        without forming them."""
        if gate is None:
            return np.full(len(mp), len(z), np.int64)
        return window_counts(z[:, 0], mp.z[:, 0], np.sqrt(gate * (mp.S[:, 0, 0] + self.noise(contact_R)[0])))

    def pairs(self, mixture: Mixture, z: np.ndarray, contact_R: np.ndarray | None = None,
              gate: float | None = None, mp: MeasurementPrediction | None = None) -> Pairs:
        """The pairs of the predicted ``mixture`` and the contacts z (N, 2) (from `contacts`) with squared
        Mahalanobis distance <= ``gate`` (None: all J x N pairs); ``mp`` its `prediction` when made already."""
        mp = self.prediction(mixture) if mp is None else mp
        j, i = _gated(mp, z, gate, self.noise(None), self.period)
        keep, nu, log_likelihood = gate_kernels.gated_pairs(j, i, _float(z), _float(mp.z), mp.S, mp.S_inv, mp.log_det_S,
                                                            gate_kernels.NONE, *_limit(gate), self.period)
        return Pairs(j[keep], i[keep], nu, log_likelihood, len(z), mp)


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

    def pairs(self, mixture, z, contact_R=None, gate=None, mp=None):
        if contact_R is None:  # fixes with the model's own noise
            contact_R = np.broadcast_to(self.measurement.R, (len(z), 2, 2))
        mp = self.prediction(mixture) if mp is None else mp
        j, i = _gated(mp, z, gate, self.noise(contact_R), self.period)
        keep, nu, log_likelihood = gate_kernels.gated_pairs(j, i, _float(z), _float(mp.z), mp.S, mp.S_inv, mp.log_det_S,
                                                            _float(contact_R), *_limit(gate), 0.0)
        return Pairs(j[keep], i[keep], nu, log_likelihood, len(z), mp, contact_R)


def per_contact_logsumexp(values: np.ndarray, i: np.ndarray, n: int, floor: np.ndarray) -> np.ndarray:
    """log(exp(floor_c) + sum over the pairs of contact c of exp(values)) for every contact c: (n,).

    ``values`` (P,) belong to contacts ``i`` (P,), sorted; ``floor`` (n,)
    is an extra term per contact (-inf: none). Shifted by each contact's
    maximum, so nothing overflows; a contact whose terms are all -inf gets -inf.
    """
    top = floor.copy()
    if len(i):
        starts = np.flatnonzero(run_starts(i))
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
