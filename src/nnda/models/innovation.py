"""The extended pair features: the three kinematic ones plus what the track's IMM knows.

The kinematic features of Vargas Avila (2015) (`nnda.models.features.KINEMATIC`) judge a candidate
from the track's last two *contacts*: the speed and course implied by two
noisy fixes 2 s apart carry tens of m/s of noise, which caps any classifier
near 93-94 % accuracy (measured with an MLP and with boosted trees). The track's IMM filter has already
averaged that noise away; these features read its prediction for the scan
of the candidate C (polar z_c = [range m, azimuth rad]):

* ``innovation_range_sigma``, ``innovation_azimuth_sigma``: the innovation
  nu = z_c - z_pred (azimuth wrapped) divided component-wise by the
  predicted standard deviations sqrt(S_rr), sqrt(S_aa) (dimensionless; 0 on
  the prediction, 1 one sigma away);
* ``mahalanobis_d2``: nu^T S^-1 nu (chi-square with 2 degrees of freedom
  for the track's own contact);
* ``log_det_s``: log |S| (S in m^2 rad^2): how uncertain the prediction is;
* ``ct_probability``: the predicted probability mu_CT(k|k-1) of the
  coordinated-turn model (how much the track is manoeuvring);
* ``track_age_s``: time from the track's first contact to the scan (s).

z_pred and S are those of the IMM's combined prediction (the gating
prediction of every IMM tracker, `IMM.combined_measurement`), made over the
time since the track's last update. That time is the kinematic ΔT (column 3):
tracks are updated only by contacts, so it is not repeated.

The training-pair extraction (`nnda.models.pairs`) calls `innovation_features`
with the trackers' IMM (`IMM.for_sensor`); the neural tracker calls
`scan_features`, which runs the same compiled kernels (`candidates`,
`kinematic`, `innovation`) in one call and gives the same pairs and bits
(tested), so the network is trained on exactly what the tracker computes.
"""

from __future__ import annotations

import numpy as np

from nnda.errors import ModelError
from nnda.filters.imm import IMM, IMMPrediction
from nnda.filters.imm_kernels import kernel_array
from nnda.filters.kalman import MeasurementPrediction
from nnda.filters.motion import CoordinatedTurn
from nnda.models import feature_kernels
from nnda.models.features import KINEMATIC, FeatureSet

ADDED_NAMES = ("innovation_range_sigma", "innovation_azimuth_sigma", "mahalanobis_d2", "log_det_s",
               "ct_probability", "track_age_s")

IMM_INNOVATION = FeatureSet(
    "imm-innovation-9", 1, KINEMATIC.names + ADDED_NAMES,
    "the kinematic three plus the IMM's normalised innovation, squared Mahalanobis distance, log |S|, "
    "CT mode probability and track age",
)


def _ct_index(imm: IMM) -> int:
    found = [j for j, m in enumerate(imm.models) if isinstance(m, CoordinatedTurn)]
    if len(found) != 1:
        raise ModelError(f"{IMM_INNOVATION.name} features need an IMM with one coordinated-turn model, "
                         f"got models {[type(m).__name__ for m in imm.models]}")
    return found[0]


def innovation_features(
    imm: IMM, pred: IMMPrediction, track: np.ndarray, contacts: np.ndarray, kinematic: np.ndarray,
    age: np.ndarray, gate: MeasurementPrediction | None = None,
) -> np.ndarray:
    """Extended features (P, 9) of P pairs, columns as `IMM_INNOVATION.names`.

    ``pred`` is the IMM prediction of K tracks at the scan time; ``track``
    (P,) the pair's row in it; ``contacts`` (P, 2) the candidates' polar
    measurements [range m, azimuth rad]; ``kinematic`` (P, 3) the kinematic
    features of the same pairs (`pair_features`); ``age`` (P,) the time (s)
    from each pair's track's first contact to the scan; ``gate`` the tracks' combined measurement
    prediction (`IMM.combined_measurement` of ``pred``) when the caller has it. The azimuth
    residual of a polar measurement is wrapped, as
    `PolarMeasurement.residual`; the columns are computed in one compiled
    loop (`feature_kernels.innovation`).
    """
    n = len(track)
    if contacts.shape != (n, 2) or kinematic.shape != (n, KINEMATIC.size) or np.shape(age) != (n,):
        raise ModelError(f"innovation features: expected contacts ({n}, 2), kinematic ({n}, 3) and age ({n},), "
                         f"got {contacts.shape}, {kinematic.shape}, {np.shape(age)}")
    gate = imm.combined_measurement(pred) if gate is None else gate
    return feature_kernels.innovation(kinematic, np.asarray(track, np.int64), np.asarray(contacts, float), gate.z,
                                      gate.S, gate.S_inv, gate.log_det_S, pred.state.mu, _ct_index(imm),
                                      np.asarray(age, float), imm.polar)


def scan_features(imm: IMM, pred: IMMPrediction, gate: MeasurementPrediction | None, p1: np.ndarray, t1: np.ndarray,
                  p2: np.ndarray, t2: np.ndarray, az2: np.ndarray, born: np.ndarray, xy: np.ndarray, z: np.ndarray,
                  time: float, extended: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The gated pairs of one scan's K tracks and their features, in one compiled call
    (`feature_kernels.scan_features`): `candidate_pairs` of the tracks' last contacts ``p2`` (K, 2) m at
    ``t2`` (K,) s with azimuths ``az2`` (K,) rad and the N contacts ``xy`` (N, 2) m, ``z`` (N, 2) [range m,
    azimuth rad] at ``time`` s; `pair_features` from the contacts before them, ``p1`` (K, 2) at ``t1`` (K,);
    and, if ``extended``, `innovation_features` on ``pred``, its combined measurement prediction ``gate`` and
    the times of the tracks' first contacts ``born`` (K,) s (both unread otherwise: None and any array).

    Returns the pairs' track (P,), contact (P,) and features (P, 3) or (P, 9), the same as those functions
    give. Unchecked: for the neural tracker, whose arrays its scan loop has checked.
    """
    if extended:
        state, args = pred.state, (gate.z, gate.S, gate.S_inv, gate.log_det_S)
        mu, ct = state.mu, _ct_index(imm)
    else:
        args, mu, ct = (np.empty((0, 2)), np.empty((0, 2, 2)), np.empty((0, 2, 2)), np.empty(0)), np.empty((0, 1)), 0
    # the tracker's columns are views of its tables: copied here (K and N rows), so the kernel compiles once
    p1, t1, p2, t2 = kernel_array(p1), kernel_array(t1), kernel_array(p2), kernel_array(t2)
    az2, born, xy, z = kernel_array(az2), kernel_array(born), kernel_array(xy), kernel_array(z)
    return feature_kernels.scan_features(p1, t1, p2, t2, az2, xy, z, float(time), born, *args, mu, ct,
                                         imm.polar, extended)
