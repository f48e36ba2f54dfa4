"""The EK-PHD and UK-PHD with Frencl (2014)'s heading models ([x, y, v, alpha]: modified NCSHT, HM-map composite)."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.pedestrian.walkers import generate_walkers, radar_sensor
from nnda.data.scenario import Sensor
from nnda.errors import ConfigError
from nnda.filters import unscented
from nnda.filters.ground_motion import BIRTH_HEADINGS, ModifiedNCSHT, ncsht_to_cv
from nnda.filters.motion import ConstantVelocity
from nnda.tracking.phd.birth import measurement_births
from nnda.tracking.registry import make_tracker
from tolerances import assert_cov, assert_state

SCENE = PEDESTRIAN_SCENES["walk-test4"]
H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])


def _walk(n: int = 15, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A walker heading east along the corridor's middle with a gentle wiggle, and its noisy fixes (n, 2)."""
    rng = np.random.default_rng(seed)
    t = np.arange(1, n + 1, dtype=float)
    truth = np.column_stack([5.0 + 1.4 * t, 25.0 + 1.5 * np.sin(t / 3.0)])
    return truth, truth + rng.normal(0.0, SCENE.radar.sigma_m, truth.shape)


def _oracle_params(motion: str, first: np.ndarray, cov: np.ndarray, **extra) -> dict:
    return {"motion": motion, "pd": 1.0, "ps": 1.0, "clutter": 0.0, "gate": None, "prune_threshold": 1e-12,
            "extraction_scans": 1,  # reported from the first scan
            "birth": {"kind": "static", "every_scan": False,
                      "components": [{"weight": 1.0, "mean": first.tolist(), "covariance": cov.tolist()}]},
            **extra}


@pytest.mark.parametrize(("motion", "extra"), [("ncsht", {}), ("hm-map", {"hm_map": "corridor"}),
                                               ("hm-map", {"hm_map": "corridor", "hm_jacobian": "printed"})])
@pytest.mark.parametrize("kind", ["ekphd", "ukphd"])
def test_one_target_without_clutter_at_pd_1_is_the_single_target_filter(kind, motion, extra):
    """One component of weight 1, no clutter, p_D = p_S = 1, every contact the target's: the PHD's update
    gives the detection copy weight 1 and the missed copy 0, so it is the EKF (EK-PHD) or the UKF with a
    linear update (UK-PHD) on the same motion model, written out here step by step."""
    _, z = _walk()
    m0, P0 = np.array([z[0, 0], z[0, 1], 1.2, 0.1]), np.diag([0.25**2, 0.25**2, 0.5**2, 0.3**2])
    tracker = make_tracker(kind, (radar_sensor(SCENE),), _oracle_params(motion, m0, P0, **extra))
    model, R = tracker.motion, np.eye(2) * SCENE.radar.sigma_m**2
    x, P = m0, P0
    for k, zk in enumerate(z, start=1):
        if k > 1:
            if kind == "ekphd":
                fx, F = model.transition(x, np.asarray(1.0))
                x, P = fx, F @ P @ F.T + model.noise(np.asarray(1.0))
            else:
                x, P = (a[0] for a in unscented.predict(x[None], P[None], model, 1.0))
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        x, P = x + K @ (zk - H @ x), P - K @ S @ K.T
        out = tracker.step(Scan(k, float(k), zk[None]))
        assert len(tracker.mixture) == 1 and tracker.mixture.weights[0] == pytest.approx(1.0, rel=1e-12)
        assert_state(tracker.mixture.means[0], x, P)
        assert_cov(tracker.mixture.covariances[0], P)
        cv, cv_P = ncsht_to_cv(x, P)  # what the tracker reports: nnda's [x, vx, y, vy]
        assert_state(out.state[0], cv, cv_P)


def test_the_unscented_prediction_of_a_linear_model_is_the_kalman_prediction():
    rng = np.random.default_rng(0)
    x, A = rng.normal(size=(5, 4)), rng.normal(size=(5, 4, 4))
    P = A @ A.transpose(0, 2, 1) + np.eye(4)
    cv = ConstantVelocity(1.0)
    m, Pu = unscented.predict(x, P, cv, np.full(5, 2.0))
    fx, F = cv.transition(x, np.full(5, 2.0))
    assert_state(m, fx, Pu)
    assert_cov(Pu, F @ P @ F.transpose(0, 2, 1) + cv.noise(np.full(5, 2.0)))


def test_the_ncsht_newborn_ring_shares_each_contacts_birth_weight():
    """Measurement-driven birth in [x, y, v, alpha]: BIRTH_HEADINGS components per unexplained contact at
    evenly spaced headings, sharing its weight; the speed is the CV newborn's (Rayleigh) mean and std."""
    xy = np.array([[1.0, 2.0], [10.0, 20.0], [5.0, 5.0]])
    cov = np.broadcast_to(np.eye(2) * 0.0625, (3, 2, 2))
    explained = np.array([0.0, 1.0, 0.5])
    born = measurement_births(xy, cov, explained, 0.1, 1.5, ModifiedNCSHT(), 7)
    assert len(born) == 2 * BIRTH_HEADINGS and born.weights.sum() == pytest.approx(0.1, rel=1e-12)
    first = born.weights[:BIRTH_HEADINGS]
    assert np.allclose(first, first[0]) and first.sum() == pytest.approx(0.1 / 1.5, rel=1e-12)
    np.testing.assert_array_equal(born.means[:BIRTH_HEADINGS, :2], np.broadcast_to(xy[0], (BIRTH_HEADINGS, 2)))
    headings = born.means[:BIRTH_HEADINGS, 3]
    assert np.allclose(np.diff(headings), 2 * np.pi / BIRTH_HEADINGS) and headings.min() >= -np.pi
    assert born.means[0, 2] == pytest.approx(1.5 * np.sqrt(np.pi / 2))
    np.testing.assert_array_equal(born.labels, np.arange(7, 7 + 2 * BIRTH_HEADINGS))


def test_the_ncsht_ekphd_follows_the_test2_walker_from_measurement_birth():
    ds = generate_walkers(PEDESTRIAN_SCENES["walk-test2"], run=0)
    params = {"preset": "pedestrian", "motion": "ncsht", "pd": 0.99, "clutter": 5.0,
              "clutter_area_m2": 2500.0, "birth": {"kind": "measurement", "rate": 0.1, "speed_sigma_m_s": 1.5}}
    tracker = make_tracker("ekphd", ds.scenario.sensors, params)
    assert isinstance(tracker.motion, ModifiedNCSHT) and tracker.views[0].volume == 2500.0
    errors = []
    for scan in ds.scans():
        out = tracker.step(scan)
        here = ds.truth.scan == scan.index
        if scan.index > 5 and here.any() and len(out.state):
            errors.append(np.hypot(out.state[:, 0] - ds.truth.x[here][0], out.state[:, 2] - ds.truth.y[here][0]).min())
    assert len(errors) > 20 and np.median(errors) < 1.0


def test_heading_models_are_refused_where_they_cannot_work():
    with pytest.raises(ConfigError, match="polar radar measurement.*Cartesian position fixes"):
        make_tracker("ekphd", Sensor(), {"motion": "ncsht"})
    with pytest.raises(ConfigError, match="hm_map"):
        make_tracker("ekphd", (radar_sensor(SCENE),), {"motion": "hm-map"})
    with pytest.raises(ConfigError, match="hm_map"):
        make_tracker("ekphd", (radar_sensor(SCENE),), {"motion": "ncsht", "hm_map": "plus"})
    with pytest.raises(ConfigError, match=r"\[x, y, v, alpha\]"):
        make_tracker("ekphd", (radar_sensor(SCENE),), {"motion": "ncsht", "birth": {
            "kind": "static", "components": [{"weight": 1.0, "mean": [0.0] * 5, "covariance": np.eye(5).tolist()}]}})


def test_headings_either_side_of_pi_merge_on_the_circle():
    """Two components heading west, one just below pi and one just above -pi: one heading, so they merge
    (angles = (3,)) into the weighted mean on the circle; compared as plain numbers they are 2 pi apart."""
    from nnda.filters.mixture import Mixture, merge

    P = np.diag([0.1, 0.1, 0.1, 0.05])
    mix = Mixture(np.array([0.6, 0.4]), np.array([[0.0, 0, 1.5, np.pi - 0.05], [0.1, 0, 1.5, -np.pi + 0.05]]),
                  np.stack([P, P]), np.array([1, 2]))
    assert len(merge(mix, 4.0, "candidate")) == 2
    one = merge(mix, 4.0, "candidate", ModifiedNCSHT.angles)
    assert len(one) == 1 and one.labels[0] == 1
    heading = 0.6 * (np.pi - 0.05) + 0.4 * (np.pi + 0.05)
    assert one.means[0, 3] == pytest.approx(heading, rel=1e-12)
    assert one.covariances[0, 3, 3] == pytest.approx(0.05 + 0.6 * 0.4 * 0.1**2, rel=1e-9)


@pytest.mark.parametrize("heading", [0.0, np.pi / 2, np.pi - 0.01, -np.pi + 0.01])
def test_a_walker_is_reported_once_whatever_its_heading(heading):
    """The newborn ring spans [-pi, pi): a walker heading west is seen by components on both sides of the
    cut, which merge on the circle, so it gets one estimate, as one heading east does."""
    rng = np.random.default_rng(0)
    tracker = make_tracker("ekphd", (radar_sensor(SCENE),), {
        "preset": "pedestrian", "motion": "ncsht", "pd": 0.99, "clutter": 1.0, "clutter_area_m2": 5000.0,
        "birth": {"kind": "measurement", "rate": 0.1, "speed_sigma_m_s": 1.5}})
    p, counts = np.array([50.0, 25.0]), []
    for k in range(1, 26):
        p = p + 1.4 * np.array([np.cos(heading), np.sin(heading)])
        counts.append(len(tracker.step(Scan(k, float(k), (p + rng.normal(0, 0.25, 2))[None])).state))
    assert counts[5:] == [1] * 20
