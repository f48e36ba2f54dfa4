"""JPDA: the IMM-PDA update and the tracker (its marginals are tested in test_marginals.py).

Behaviour every model-free tracker shares (S1/S2, no clutter, crossing,
gaps, bad scans) is checked for JPDA in test_trackers_common.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Sensor
from nnda.data.sensor import cart_to_polar
from nnda.errors import ConfigError
from nnda.filters import kalman
from nnda.filters.imm import IMM
from nnda.filters.motion import ConstantVelocity
from nnda.study.metrics import run_metrics
from nnda.tracking import gating
from nnda.tracking.jpda import JPDATracker, best_pairs, pda_update
from nnda.tracking.lifecycle import THESIS_LIFECYCLE
from nnda.tracking.marginals import jpda_marginals, log_miss_weight
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker
from nnda.tracking.tracker import ScanContacts
from tolerances import RTOL, assert_cov, assert_state

# ---------------------------------------------------------------------------------- the update

def _prediction(imm: IMM, dt: float = 2.0):
    z1 = np.array([[12_000.0, 0.50], [15_000.0, 2.0]])
    z2 = np.array([[12_150.0, 0.51], [15_100.0, 2.01]])
    return imm.predict(imm.initialise(z1, z2, 0.0, 2.0), dt)


def _update(imm: IMM, pred, z, beta, beta0):
    """`pda_update` from dense (K, N) association probabilities (pairs: where beta > 0)."""
    t, c = np.nonzero(beta > 0)
    return pda_update(pred, np.arange(len(beta)), t, z[c], beta[t, c], beta0, imm.polar)


def test_best_pair_per_track_takes_the_first_of_equals():
    track = np.array([0, 0, 0, 1, 2, 2])
    assert best_pairs(track, np.array([0.2, 0.5, 0.5, 0.1, 0.3, 0.6])).tolist() == [1, 3, 5]


def test_certain_association_is_the_plain_imm_update():
    imm = IMM()
    pred = _prediction(imm)
    z = np.array([[12_310.0, 0.522], [9_000.0, 1.0], [15_190.0, 2.021]])
    beta = np.zeros((2, 3))
    beta[0, 0] = beta[1, 2] = 1.0
    got = _update(imm, pred, z, beta, np.zeros(2))
    want = imm.update(pred, z[[0, 2]])
    assert_state(got.x, want.x, want.P)
    assert_cov(got.P, want.P)
    np.testing.assert_allclose(got.mu, want.mu, rtol=RTOL)
    # no association at all leaves the prediction
    none = _update(imm, pred, z, np.zeros((2, 3)), np.ones(2))
    np.testing.assert_allclose(none.x, pred.state.x)
    np.testing.assert_allclose(none.P, pred.state.P)


def test_update_of_some_tracks_reads_them_from_the_whole_prediction():
    """`pda_update` with ``rows`` (the tracker's call: only the arrays it reads are taken) is the update of the
    prediction taken at those rows, bit for bit."""
    imm = IMM()
    z1 = np.array([[12_000.0, 0.50], [15_000.0, 2.0], [9_000.0, 1.0], [20_000.0, 4.0]])
    pred = imm.predict(imm.initialise(z1, z1 + [[150.0, 0.01]], 0.0, 2.0), 2.0)
    z = np.array([[12_310.0, 0.522], [9_000.0, 1.0], [9_290.0, 1.012], [20_200.0, 4.01]])
    rows, t, c = np.array([0, 2, 3]), np.array([0, 0, 1, 2]), np.array([0, 2, 2, 3])
    beta, beta0 = np.array([0.5, 0.2, 0.9, 0.6]), np.array([0.3, 0.1, 0.4])
    want = pda_update(pred.take(rows), np.arange(3), t, z[c], beta, beta0, imm.polar)
    got = pda_update(pred, rows, t, z[c], beta, beta0, imm.polar)
    for a, b in ((got.x, want.x), (got.P, want.P), (got.mu, want.mu)):
        assert a.shape[0] == 3
        np.testing.assert_array_equal(a, b)


def test_single_model_update_is_the_textbook_pda():
    imm = IMM(models=(ConstantVelocity(),), tpm=((1.0,),), mu0=(1.0,))
    pred = _prediction(imm)
    z = np.array([[12_310.0, 0.522], [12_250.0, 0.524], [12_380.0, 0.519]])
    beta = np.array([[0.5, 0.2, 0.2], [0.0, 0.0, 0.0]])
    beta0 = np.array([0.1, 1.0])
    got = _update(imm, pred, z, beta, beta0)
    mp, x, P = pred.measurement, pred.state.x[0, 0], pred.state.P[0, 0]
    W = mp.PHt[0, 0] @ np.linalg.inv(mp.S[0, 0])
    nus = [imm.measurement.residual(zj, mp.z[0, 0]) for zj in z]
    nu = sum(b * n for b, n in zip(beta[0], nus))
    spread = sum(b * np.outer(n, n) for b, n in zip(beta[0], nus)) - np.outer(nu, nu)
    P_full = P - W @ mp.S[0, 0] @ W.T
    P_want = beta0[0] * P + (1 - beta0[0]) * P_full + W @ spread @ W.T
    assert_state(got.x[0, 0], x + W @ nu, P_want)
    assert_cov(got.P[0, 0], P_want)
    np.testing.assert_allclose(got.x[1], pred.state.x[1])


def test_each_imm_model_makes_the_textbook_pda_with_its_own_association_probabilities():
    """Two tracks of the CV + CT IMM, two contacts each: every model's state and covariance are
    the textbook PDA with the pair probabilities split by that model's responsibility for the contact, and the
    mode probabilities are the IMM-PDAF's."""
    imm = IMM()
    pred = _prediction(imm)
    z = np.array([[12_310.0, 0.522], [12_250.0, 0.5245], [15_190.0, 2.021], [15_120.0, 2.017]])
    beta = np.array([[0.5, 0.3, 0.0, 0.0], [0.0, 0.0, 0.6, 0.2]])
    beta0 = 1.0 - beta.sum(axis=1)
    got = _update(imm, pred, z, beta, beta0)
    mp, st = pred.measurement, pred.state
    for k in range(2):
        own = beta[k] > 0
        nu = imm.measurement.residual(z[own][:, None, :], mp.z[k][None])  # (N_k, r, 2)
        lik = np.exp(kalman.gaussian_log_likelihood(kalman.mahalanobis_2x2(nu, mp.S_inv[k][None]),
                                                    mp.log_det_S[k][None]))  # (N_k, r)
        split = beta[k, own][:, None] * st.mu[k] * lik / (st.mu[k] * lik).sum(axis=1, keepdims=True)  # (N, r)
        mu = beta0[k] * st.mu[k] + split.sum(axis=0)
        np.testing.assert_allclose(got.mu[k], mu / mu.sum(), rtol=RTOL)
        for j in range(2):
            b, b0 = split[:, j] / mu[j], beta0[k] * st.mu[k, j] / mu[j]
            W = mp.PHt[k, j] @ np.linalg.inv(mp.S[k, j])
            combined = b @ nu[:, j]
            spread = np.einsum("n,na,nb->ab", b, nu[:, j], nu[:, j]) - np.outer(combined, combined)
            P = st.P[k, j] - (1.0 - b0) * W @ mp.S[k, j] @ W.T + W @ spread @ W.T
            assert_state(got.x[k, j], st.x[k, j] + W @ combined, P)
            assert_cov(got.P[k, j], P)


def test_mode_probabilities_of_an_isolated_track_are_the_imm_pdaf_ones():
    imm = IMM()
    pred = _prediction(imm).take([0])
    z = np.array([[12_310.0, 0.522], [12_240.0, 0.5235]])
    pd, gate, density = 0.9, 9.21, 1e-3
    log_ratio = np.log(pd) + imm.log_likelihood(pred, z) - np.log(density)
    m = jpda_marginals(np.zeros(2, np.int64), np.arange(2), log_ratio[0], 1, log_miss_weight(pd, gate), 100)
    got = _update(imm, pred, z, m.beta[None], m.beta0)
    mp = pred.measurement
    nu = imm.measurement.residual(z[:, None, :], mp.z[0][None])  # (N, r, 2)
    lik = np.exp(kalman.gaussian_log_likelihood(kalman.mahalanobis_2x2(nu, mp.S_inv[0][None]),
                                                mp.log_det_S[0][None]))  # (N, r)
    pg = 1 - np.exp(-gate / 2)
    want = pred.state.mu[0] * ((1 - pd * pg) + pd / density * lik.sum(axis=0))
    np.testing.assert_allclose(got.mu[0], want / want.sum(), rtol=RTOL)


# ---------------------------------------------------------------------------------- the tracker

def _confirmed_track(tracker: JPDATracker, n_scans: int = 6) -> np.ndarray:
    """Feed one target moving east at 100 m/s (no clutter); returns its next expected position."""
    for k in range(1, n_scans + 1):
        x, y = -5_000.0 + 200.0 * k, 12_000.0
        r, az = cart_to_polar(np.array([x]), np.array([y]))
        out = tracker.step(Scan(k, 2.0 * k, np.column_stack([r, az])))
    assert out.status.tolist() == [TrackStatus.CONFIRMED]
    return np.array([-5_000.0 + 200.0 * (n_scans + 1), 12_000.0])


def _polar(points) -> np.ndarray:
    p = np.asarray(points, float)
    return np.column_stack(cart_to_polar(p[:, 0], p[:, 1]))


def test_reported_contact_is_the_best_one_if_it_beats_no_detection():
    tracker = make_tracker("jpda", Sensor(), {"clutter_density": 1e-3})
    nxt = _confirmed_track(tracker)
    z = _polar([nxt + [5_000.0, 0.0], nxt + [10.0, 5.0], nxt + [40.0, -30.0]])
    out = tracker.step(Scan(7, 14.0, z))
    assert out.contact.tolist() == [1]


@pytest.mark.parametrize("n, odds, reported", [(1, 10.0, True), (1, 0.1, False), (2, 1.5, True), (2, 0.6, False)])
def test_contacts_are_reported_when_likelier_than_no_detection(n, odds, reported):
    # one track, n contacts at squared distance 7 (inside the gate) on either side of the prediction:
    # each beta_j / beta_0 equals P_D l / (lambda (1 - P_D P_G)); once the track is confirmed, set
    # lambda to make that ratio `odds`. With two contacts and odds 1.5, beta_j = 0.375 > beta_0 = 0.25.
    tracker = make_tracker("jpda", Sensor())
    _confirmed_track(tracker)
    pred = tracker.filter.predict(tracker.tracks.filt, 14.0 - tracker.tracks.t2)
    mp = tracker.filter.combined_measurement(pred)
    step = np.linalg.cholesky(mp.S[0]) @ [np.sqrt(7.0), 0.0]
    z = mp.z + np.array([step, -step])[:n]
    log_lik = tracker.filter.log_likelihood(pred, z)[0]
    assert log_lik[0] == pytest.approx(log_lik[-1], abs=0.05)
    density = 0.9 * np.exp(log_lik[0] - log_miss_weight(0.9, 9.21)) / odds
    tracker.config = tracker.config.model_copy(update={"clutter_density": density})
    out = tracker.step(Scan(7, 14.0, z))
    assert (out.contact[0] >= 0) == reported


def _scan(z, xy, sensor: Sensor | None = None) -> ScanContacts:
    """A checked scan at t = 2 s from the radar at the origin (or ``sensor``)."""
    return ScanContacts(1, 2.0, 0, IMM.for_sensor(sensor or Sensor()), z, xy)


def test_clutter_density_estimates():
    sensor = Sensor()
    z = _polar([[0.0, 10_000.0], [1_000.0, 10_000.0], [0.0, 12_500.0], [0.0, 20_000.0]])
    xy = np.array([[0.0, 10_000.0], [1_000.0, 10_000.0], [0.0, 12_500.0], [0.0, 20_000.0]])
    at = np.array([0, 3])
    scan = make_tracker("jpda", sensor, {"clutter_density": "scan"}).clutter_density(_scan(z, xy), at)
    np.testing.assert_allclose(scan, 4 / (25_000.0 * 2 * np.pi))
    local = make_tracker("jpda", sensor, {"clutter_radius_m": 2_000.0}).clutter_density(_scan(z, xy), at)
    area = (2 * 2_000.0) ** 2  # the square of half-side clutter_radius_m
    np.testing.assert_allclose(local, [2 / area * 10_000.0, 1 / area * 20_000.0])
    fixed = make_tracker("jpda", sensor, {"clutter_density": 5e-4}).clutter_density(_scan(z, xy), at)
    np.testing.assert_allclose(fixed, 5e-4)


def test_tracks_s1_with_the_enumeration_capped():
    ds = generate(PRESETS["S1"], seed=2)
    full = make_tracker("jpda", ds.scenario.sensor, {"lifecycle": THESIS_LIFECYCLE})
    capped = make_tracker("jpda", ds.scenario.sensor, {"max_joint_events": 2, "lifecycle": THESIS_LIFECYCLE})
    metrics = [run_metrics(ds, [t.step(s) for s in ds.scans()]) for t in (full, capped)]
    assert full.n_approximated == 0 < capped.n_approximated <= capped.n_clusters
    for m in metrics:
        assert m.confirmed_tracks - m.false_tracks >= 4 and m.lost_targets == 0
    capped.reset()
    assert capped.n_approximated == capped.n_clusters == 0


@pytest.mark.parametrize("params, field", [
    ({"pd": 0.0}, "pd"), ({"pd": 1.5}, "pd"), ({"clutter_density": -1.0}, "clutter_density"),
    ({"clutter_density": "global"}, "clutter_density"), ({"max_joint_events": 0}, "max_joint_events"),
    ({"clutter_radius_m": 0.0}, "clutter_radius_m"), ({"gate": 0.0}, "gate"), ({"pg": 0.9}, "pg"),
])
def test_bad_config_is_refused(params, field):
    with pytest.raises(ConfigError, match=rf"invalid jpda config[\s\S]*(: | - ){field}\b"):
        make_tracker("jpda", Sensor(), params)


def test_k_d_tree_gating_gives_the_dense_gatings_results(monkeypatch):
    # S6 with 400 clutter points: tracks x contacts passes the 60k-pair switch from the fourth scan on
    sc = PRESETS["S6"].model_copy(update={"duration_s": 12.0, "clutter": PRESETS["S6"].clutter.model_copy(
        update={"count": 400})})
    ds = generate(sc, seed=4)
    sizes = []

    class Sizes(JPDATracker):
        def associate(self, tracks, pred, scan):
            sizes.append(len(tracks) * len(scan.z))
            return super().associate(tracks, pred, scan)

    runs, switch = [], gating.DENSE_PAIRS
    for dense_pairs in (switch, 10**12):
        monkeypatch.setattr(gating, "DENSE_PAIRS", dense_pairs)
        tracker = Sizes(ds.scenario.sensor)
        runs.append([tracker.step(scan) for scan in ds.scans()])
    assert max(sizes) > switch > min(sizes)  # both paths ran in the default run
    # the same pairs, but the tree path computes their distances on gathered arrays: equal to rounding
    for a, b in zip(*runs):
        for field in ("track_id", "status", "contact"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
        assert_state(a.state, b.state, b.covariance)
        assert_cov(a.covariance, b.covariance)
