"""JPDA: marginals against brute-force enumeration, the fallback, the IMM-PDA update, the tracker.

Behaviour every model-free tracker shares (S1/S2, no clutter, crossing,
gaps, bad scans) is checked for JPDA in test_trackers_common.py.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.special import logsumexp

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
from nnda.tracking.jpda import JPDATracker, best_pairs, pair_likelihoods, pda_update
from nnda.tracking.marginals import Marginals, clusters, jpda_marginals, log_miss_weight, loopy_marginals
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker
from nnda.tracking.tracker import ScanContacts
from tolerances import RTOL, assert_cov, assert_state


def brute_force(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float) -> tuple[np.ndarray, np.ndarray]:
    """Marginals by listing every joint assignment of all tracks at once (no clusters)."""
    K, N = gate.shape
    beta, beta0, total = np.zeros((K, N)), np.zeros(K), 0.0
    for event in itertools.product(*[[-1, *np.flatnonzero(gate[t])] for t in range(K)]):
        used = [j for j in event if j >= 0]
        if len(used) != len(set(used)):
            continue
        w = np.exp(sum(log_miss if j < 0 else log_ratio[t, j] for t, j in enumerate(event)))
        total += w
        for t, j in enumerate(event):
            if j < 0:
                beta0[t] += w
            else:
                beta[t, j] += w
    return beta / total, beta0 / total


def marginals(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float, max_events: int
              ) -> tuple[Marginals, np.ndarray]:
    """`jpda_marginals` of the pairs where ``gate`` (K, N) is True; also returns its beta as (K, N)."""
    t, c = np.nonzero(gate)
    m = jpda_marginals(t, c, log_ratio[t, c], gate.shape[0], log_miss, max_events)
    dense = np.zeros(gate.shape)
    dense[t, c] = m.beta
    return m, dense


def loopy(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float) -> tuple[np.ndarray, np.ndarray]:
    """`loopy_marginals` of the pairs where ``gate`` is True, beta as (K, N)."""
    t, c = np.nonzero(gate)
    beta, beta0 = loopy_marginals(t, c, log_ratio[t, c], gate.shape[0], log_miss)
    dense = np.zeros(gate.shape)
    dense[t, c] = beta
    return dense, beta0


def test_two_tracks_sharing_a_contact_match_brute_force():
    # track 0 gates contacts 0 and 1, track 1 gates 1 and 2: one cluster of two tracks
    gate = np.array([[1, 1, 0], [0, 1, 1]], bool)
    log_ratio = np.log(np.array([[4.0, 2.0, 1.0], [1.0, 6.0, 0.5]]))  # 1.0: outside the gate
    log_miss = np.log(0.1)
    m, got = marginals(gate, log_ratio, log_miss, max_events=10_000)
    beta, beta0 = brute_force(gate, log_ratio, log_miss)
    np.testing.assert_allclose(got, beta, rtol=RTOL, atol=RTOL)  # probabilities: atol on their scale, 1
    np.testing.assert_allclose(m.beta0, beta0, rtol=RTOL)
    # by hand: the 8 feasible events have weights
    # {miss,miss} .01, {0,miss} .4, {1,miss} .2, {miss,1} .6, {miss,2} .05, {0,1} 24, {0,2} 2, {1,2} 1
    total = 0.01 + 0.4 + 0.2 + 0.6 + 0.05 + 24 + 2 + 1
    assert got[0, 0] == pytest.approx((0.4 + 24 + 2) / total)
    assert got[1, 1] == pytest.approx((0.6 + 24) / total)
    assert m.beta0[1] == pytest.approx((0.01 + 0.4 + 0.2) / total)
    assert not m.approximated.any() and m.cluster.tolist() == [0, 0]


@pytest.mark.parametrize("seed", range(40))
def test_random_gates_match_brute_force(seed):
    rng = np.random.default_rng(seed)
    K, N = rng.integers(1, 6), rng.integers(1, 6)
    gate = rng.random((K, N)) < 0.5
    log_ratio = rng.normal(0.0, 2.0, (K, N))
    log_miss = float(rng.normal(-2.0, 1.0))
    m, got = marginals(gate, log_ratio, log_miss, max_events=10_000)
    beta, beta0 = brute_force(gate, log_ratio, log_miss)
    np.testing.assert_allclose(got, beta, atol=RTOL)
    np.testing.assert_allclose(m.beta0, beta0, atol=RTOL)
    np.testing.assert_allclose(got.sum(axis=1) + m.beta0, 1.0)


def test_clusters_join_tracks_through_shared_contacts():
    gate = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [1, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 0]], bool)
    n, label = clusters(*np.nonzero(gate), 5)
    assert n == 3 and label.tolist() == [0, 1, 0, 1, 2]
    n, label = clusters(*np.nonzero(np.eye(3, dtype=bool)), 3)  # nothing shared
    assert n == 3 and label.tolist() == [0, 1, 2]
    # contact indices need not be compact: the same graph with contacts 1000 apart
    t, c = np.nonzero(gate)
    assert clusters(t, 1000 * c + 7, 5)[1].tolist() == [0, 1, 0, 1, 2]


def test_cap_falls_back_to_belief_propagation():
    # a chain (no cycle): belief propagation is exact there
    gate = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1]], bool)
    rng = np.random.default_rng(7)
    log_ratio = rng.normal(1.0, 1.5, gate.shape)
    exact = brute_force(gate, log_ratio, -2.0)
    m, got = marginals(gate, log_ratio, -2.0, max_events=5)
    assert m.approximated.tolist() == [True]
    np.testing.assert_allclose(got, exact[0], atol=1e-9)
    np.testing.assert_allclose(m.beta0, exact[1], atol=1e-9)
    # with a cycle (two tracks, two shared contacts) it is an approximation, close to the truth
    gate = np.ones((2, 2), bool)
    log_ratio = np.log(np.array([[3.0, 1.0], [1.0, 2.0]]))
    beta, beta0 = loopy(gate, log_ratio, np.log(0.2))
    exact = brute_force(gate, log_ratio, np.log(0.2))
    np.testing.assert_allclose(beta.sum(axis=1) + beta0, 1.0)
    np.testing.assert_allclose(beta, exact[0], atol=0.1)


def test_only_oversized_clusters_are_approximated():
    gate = np.zeros((3, 5), bool)
    gate[0, 0] = True  # small cluster: 2 events
    gate[1:, 1:] = True  # two tracks over four contacts: 1 + 8 + 12 = 21 events
    log_ratio = np.zeros(gate.shape)
    m, got = marginals(gate, log_ratio, np.log(0.1), max_events=20)
    assert m.approximated.tolist() == [False, True]
    exact = brute_force(gate, log_ratio, np.log(0.1))
    assert got[0, 0] == pytest.approx(exact[0][0, 0], rel=RTOL)


@pytest.mark.parametrize("seed", range(20))
def test_capped_random_gates_stay_exact_below_the_cap(seed):
    rng = np.random.default_rng(100 + seed)
    K, N = rng.integers(2, 7), rng.integers(2, 7)
    gate = rng.random((K, N)) < 0.4
    gate[0] = False  # a track with nothing in its gate: its cluster assigns no contact at all
    log_ratio = rng.normal(1.0, 2.0, (K, N))
    m, got = marginals(gate, log_ratio, -2.2, max_events=int(rng.integers(2, 30)))
    beta, beta0 = brute_force(gate, log_ratio, -2.2)
    exact = ~m.approximated[m.cluster]
    np.testing.assert_allclose(got[exact], beta[exact], atol=RTOL)
    np.testing.assert_allclose(m.beta0[exact], beta0[exact], atol=RTOL)
    np.testing.assert_allclose(got.sum(axis=1) + m.beta0, 1.0)
    assert m.beta0[0] == 1.0


def listed_events(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float, tracks: list[int], cap: int
                  ) -> tuple[bool, np.ndarray | None]:
    """Enumerate a cluster's joint events track by track, as `jpda_marginals` does.

    Returns whether the partial events listed (every option of every event,
    counted before dropping those that reuse a contact) stay within ``cap``
    and, if so, the exact beta (K, N) of the cluster's tracks.
    """
    events, listed = [((), 0.0)], 0
    for t in tracks:
        options = [-1, *np.flatnonzero(gate[t])]
        listed += len(events) * len(options)
        if listed > cap:
            return False, None
        events = [(e + (j,), w + (log_miss if j < 0 else log_ratio[t, j]))
                  for e, w in events for j in options if j < 0 or j not in e]
    beta = np.zeros(gate.shape)
    for e, w in events:
        for t, j in zip(tracks, e):
            if j >= 0:
                beta[t, j] += np.exp(w)
    return True, beta / sum(np.exp(w) for _, w in events)


@pytest.mark.parametrize("seed", range(10))
def test_exactly_the_clusters_over_the_cap_are_approximated(seed):
    # random chains and blobs of 1-9 tracks, caps around the listing sizes (some clusters are
    # dropped before any listing, others part-way)
    rng = np.random.default_rng(300 + seed)
    K, N = 24, 30
    gate = np.zeros((K, N), bool)
    t = 0
    while t < K:
        s = min(int(rng.integers(1, 10)), K - t)
        c = int(rng.integers(0, N - s))
        for i in range(s):
            gate[t + i, c + i: c + i + int(rng.integers(1, 4))] = True
        t += s
    gate &= rng.random(gate.shape) < 0.9
    log_ratio = rng.normal(0.0, 1.0, gate.shape)
    max_events = int(rng.integers(10, 300))
    m, got = marginals(gate, log_ratio, -2.0, max_events)
    for c in range(m.approximated.size):
        tracks = np.flatnonzero(m.cluster == c)
        within, beta = listed_events(gate, log_ratio, -2.0, tracks.tolist(), max_events)
        assert m.approximated[c] != within
        if within:
            np.testing.assert_allclose(got[tracks], beta[tracks], atol=RTOL)
    assert m.approximated.any() and not m.approximated.all()


def test_miss_weight():
    assert np.exp(log_miss_weight(0.9, 9.21)) == pytest.approx(1 - 0.9 * (1 - np.exp(-9.21 / 2)))
    assert np.isfinite(log_miss_weight(1.0, 2000.0))  # 1 - P_D P_G underflows in the naive form


# ---------------------------------------------------------------------------------- the update

def _prediction(imm: IMM, dt: float = 2.0):
    z1 = np.array([[12_000.0, 0.50], [15_000.0, 2.0]])
    z2 = np.array([[12_150.0, 0.51], [15_100.0, 2.01]])
    return imm.predict(imm.initialise(z1, z2, 0.0, 2.0), dt)


def _update(imm: IMM, pred, z, beta, beta0):
    """`pda_update` from dense (K, N) association probabilities (pairs: where beta > 0)."""
    t, c = np.nonzero(beta > 0)
    nu, log_lik = pair_likelihoods(pred, z, t, c, imm.measurement)
    return pda_update(pred, t, nu, log_lik, beta[t, c], beta0)


def test_pair_model_likelihoods_mix_to_the_imms():
    imm = IMM()
    pred = _prediction(imm)
    z = np.array([[12_310.0, 0.522], [9_000.0, 1.0], [15_190.0, 2.021]])
    t, c = np.array([0, 0, 1, 1]), np.array([0, 2, 1, 2])
    nu, log_lik = pair_likelihoods(pred, z, t, c, imm.measurement)
    assert nu.shape == (4, 2, 2) and log_lik.shape == (4, 2)
    mixed = logsumexp(log_lik, b=pred.state.mu[t], axis=1)
    np.testing.assert_allclose(mixed, imm.log_likelihood(pred, z)[t, c], rtol=RTOL)


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


def test_mode_probabilities_of_an_isolated_track_are_the_imm_pdaf_ones():
    imm = IMM()
    pred = _prediction(imm).take([0])
    z = np.array([[12_310.0, 0.522], [12_240.0, 0.5235]])
    pd, gate, density = 0.9, 9.21, 1e-3
    log_ratio = np.log(pd) + imm.log_likelihood(pred, z) - np.log(density)
    m, beta = marginals(np.ones((1, 2), bool), log_ratio, log_miss_weight(pd, gate), 100)
    got = _update(imm, pred, z, beta, m.beta0)
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
    full = make_tracker("jpda", ds.scenario.sensor)
    capped = make_tracker("jpda", ds.scenario.sensor, {"max_joint_events": 2})
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
