"""Where a polar radar's linearised filter stops being valid, and what the trackers do there.

The EKF gate and update of a polar sensor (range, azimuth) linearise the
measurement function at the predicted position. That holds while the
prediction's spread is small against its range from the radar; a track
that coasts near the radar (inside its blind ring, where nothing updates
it) reaches position uncertainties comparable to its range, azimuth
standard deviations of a radian, and there

* the gate accepts contacts on the far side of the radar: the wrapped
  azimuth residual and the linearised S say "2 sigma" of a contact 15 km
  away whose Cartesian Mahalanobis distance is 1,900 (measured on S1 run 1,
  gnn track 0 at scan 38, predicted range 3.1 km, range sd 3.1 km);
* the update moves the state along the tangent plane of the prediction, not
  to the contact: the posterior lands kilometres from the contact it used,
  with the small covariance of a good fix, and the velocity absorbs the
  jump (20-40 km/s runaway tracks).

A track is *poorly linearised* when its predicted azimuth standard
deviation (sqrt S_aa of the innovation covariance) exceeds
``LINEARISATION_LIMIT_RAD``, where the azimuth's second-order terms reach
about 1% of the first-order ones. For such a track the gate also requires
the contact to pass the same chi-square test in Cartesian space (the
contact's converted position and covariance against the predicted position
and its covariance, `cartesian_d2`), and the update is the
converted-measurement Kalman update (`IMM.update_position`), linear in the
position and so valid whatever the spread. Tracks whose linearisation holds
(every track of the presets but those coasting near the radar) are gated
and updated exactly as before. A position sensor is linear: never poorly
linearised.
"""

from __future__ import annotations

import numba
import numpy as np

from nnda.filters import kalman
from nnda.filters.imm import IMM, IMMPrediction, IMMState
from nnda.filters.measurement import MeasurementModel, PolarMeasurement

#: predicted azimuth standard deviation (rad) beyond which the polar linearisation is not trusted
LINEARISATION_LIMIT_RAD = 0.1


def poorly_linearised(measurement: MeasurementModel, S: np.ndarray) -> np.ndarray:
    """Which predictions of innovation covariance S (..., 2, 2) the linearised polar model does not
    describe (module docstring); all False for a position sensor. Returns (...) bool."""
    if not isinstance(measurement, PolarMeasurement):
        return np.zeros(S.shape[:-2], bool)
    return S[..., 1, 1] > LINEARISATION_LIMIT_RAD**2


def cartesian_d2(measurement: MeasurementModel, z: np.ndarray, position: np.ndarray,
                 position_cov: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances (P,) in Cartesian space of P contacts z (P, 2) (in the
    measurement's space) from predicted positions (P, 2) m with covariances (P, 2, 2) m^2: the
    contacts' converted positions and covariances (`MeasurementModel.position`) against them."""
    xy, R = measurement.position(z)
    S_inv, _ = kalman.inverse_2x2(position_cov + R)
    return kalman.mahalanobis_2x2(xy - position, S_inv)


def update(imm: IMM, pred: IMMPrediction, z: np.ndarray, detected: np.ndarray, rows: np.ndarray | None = None
           ) -> IMMState:
    """`IMM.update` of K tracks with contacts z (K, 2) where ``detected`` (K,), except that a poorly
    linearised track (any model's prediction) takes the converted-measurement update instead; a track
    without a contact keeps its prediction. ``rows`` (K,), when given, names the predicted tracks updated
    (`IMM.update`'s: one per child of a branching tracker). Unchecked (the trackers' checked contacts)."""
    state = imm.update(pred, z, detected, check=False, rows=rows)
    if not imm.polar:
        return state
    S = pred.measurement.S if rows is None else pred.measurement.S[rows]
    poor = poor_rows(S, detected, LINEARISATION_LIMIT_RAD**2)
    if not poor.size:
        return state
    xy, R = imm.measurement.position(z[poor])
    fixed = imm.update_position(pred.take(poor if rows is None else rows[poor]), xy, R)
    x, P, mu = state.x.copy(), state.P.copy(), state.mu.copy()
    x[poor], P[poor], mu[poor] = fixed.x, fixed.P, fixed.mu
    return IMMState(x, P, mu)


@numba.njit(cache=True, nogil=True)
def poor_rows(S, detected, limit):
    """The ``detected`` (K,) tracks of which some model's prediction, innovation covariance S (K, r, 2, 2), is
    poorly linearised (`poorly_linearised`: S_aa > ``limit``), ascending (one compiled pass each scan)."""
    poor = np.zeros(S.shape[0], np.bool_)
    for k in range(S.shape[0]):
        if detected[k]:
            for j in range(S.shape[1]):
                poor[k] |= S[k, j, 1, 1] > limit
    return np.flatnonzero(poor)


@numba.njit(cache=True, nogil=True)
def poor_pairs(S, rows, limit):
    """Which of the pairs of tracks ``rows`` (P,) belong to a poorly linearised track (`poorly_linearised`: its
    innovation covariance S (K, 2, 2) has S_aa > ``limit``), as indices into ``rows``, ascending (the gate's
    test of every scan, in one compiled pass)."""
    out = np.empty(rows.size, np.int64)
    n = 0
    for p in range(rows.size):
        if S[rows[p], 1, 1] > limit:
            out[n] = p
            n += 1
    return out[:n]
