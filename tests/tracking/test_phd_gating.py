"""The PHD update's gated pairs by binned contacts (`gmphd.candidates`): the same pairs, in the same order, with the
same values as every (component, contact) pair formed and then gated."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.filters import kalman
from nnda.filters.measurement import PolarMeasurement, PositionMeasurement
from nnda.filters.mixture import Mixture
from nnda.filters.unscented import UnscentedTransform
from nnda.tracking.phd import gmphd

RADAR = PolarMeasurement(30.0, 3e-3)
FIXES = PositionMeasurement(((60.0**2, 0.0), (0.0, 45.0**2)))
LINEARISATIONS = [gmphd.EKF(RADAR), gmphd.UKF(RADAR, UnscentedTransform()), gmphd.Linear(RADAR),
                  gmphd.EKF(FIXES), gmphd.Linear(FIXES)]
IDS = ["ekf", "ukf", "linear", "ekf-fixes", "linear-fixes"]


def mixture(rng, n: int, spread_m: float = 20_000.0) -> Mixture:
    """``n`` components at random positions in a ring around the radar (the azimuth's wrap at +-pi included),
    position standard deviations from 10 m to 100 km (the widest windows span every azimuth)."""
    r, az = rng.uniform(500.0, spread_m, n), rng.uniform(-np.pi, np.pi, n)
    means = np.column_stack([r * np.sin(az), rng.normal(0, 100, n), r * np.cos(az), rng.normal(0, 100, n)])
    sd = 10.0 ** rng.uniform(1.0, 5.0, n)
    A = rng.normal(0, 1, (n, 4, 4)) * 0.3 + np.eye(4)
    P = A @ A.swapaxes(1, 2) * (sd**2)[:, None, None]
    return Mixture(rng.random(n), means, P, np.arange(n))


def contacts(rng, lin, n: int, near: Mixture, spread_m: float = 20_000.0) -> np.ndarray:
    """``n`` contacts over the ring and a few at the components' own positions (pairs inside the gate), in what
    the linearisation's `contacts` takes: polar (range m, azimuth rad in [-pi, pi)) or Cartesian fixes."""
    r, az = rng.uniform(100.0, spread_m, n), rng.uniform(-np.pi, np.pi, n)
    xy = np.column_stack([r * np.sin(az), r * np.cos(az)])
    xy = np.concatenate([xy, near.means[: len(near) // 2, ::2] + rng.normal(0, 50, (len(near) // 2, 2))])
    if isinstance(lin.measurement, PolarMeasurement):
        return np.column_stack([np.hypot(*xy.T), np.arctan2(xy[:, 0], xy[:, 1])])
    return xy


def brute(lin, pred: Mixture, z: np.ndarray, contact_R, gate: float) -> gmphd.Pairs:
    """Every (component, contact) pair formed with numpy (`nnda.filters.kalman`), by contact then component,
    then those with d^2 <= gate kept: the oracle of the compiled gate."""
    mp = lin.predict_measurement(pred.means, pred.covariances)
    i, j = np.divmod(np.arange(len(z) * len(pred)), len(pred))
    linear = isinstance(lin, gmphd.Linear)  # Cartesian fixes (a radar's converted), whatever the sensor
    nu = z[i] - mp.z[j] if linear else lin.measurement.residual(z[i], mp.z[j])
    if linear:
        R = np.broadcast_to(lin.measurement.R, (len(z), 2, 2)) if contact_R is None else contact_R
        S_inv, det = kalman.inverse_2x2(mp.S[j] + R[i])
        log_det = np.log(det)
    else:
        R, S_inv, log_det = None, mp.S_inv[j], mp.log_det_S[j]
    d2 = kalman.mahalanobis_2x2(nu, S_inv)
    keep = d2 <= gate
    return gmphd.Pairs(j[keep], i[keep], nu[keep], kalman.gaussian_log_likelihood(d2, log_det)[keep], len(z), mp, R)


@pytest.mark.parametrize("lin", LINEARISATIONS, ids=IDS)
@pytest.mark.parametrize("seed", range(4))
def test_gated_pairs_are_the_brute_force_ones(lin, seed):
    """The binned candidates and the compiled gate against every pair formed and gated with numpy: the same
    pairs in the same order, innovations and likelihoods equal to 1e-9 (the same arithmetic, another code)."""
    rng = np.random.default_rng(seed)
    pred = mixture(rng, int(rng.integers(1, 120)))
    z, contact_R = lin.contacts(contacts(rng, lin, int(rng.integers(1, 300)), pred))
    for gate in (9.21, 50.0, 1e4, np.inf):
        got = lin.pairs(pred, z, contact_R, None if gate == np.inf else gate)
        want = brute(lin, pred, z, contact_R, gate)
        assert len(want.j) > 0
        for name in ("j", "i"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
        for name in ("nu", "log_likelihood"):
            np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-9, atol=0, err_msg=name)
        assert np.all(np.diff(got.i * len(pred) + got.j) > 0)  # by contact, then component
    assert len(got.j) == len(pred) * len(z)  # no gate: every pair


@pytest.mark.parametrize("lin", LINEARISATIONS, ids=IDS)
def test_no_components_no_contacts_one_contact(lin):
    rng = np.random.default_rng(7)
    pred = mixture(rng, 30)
    z, contact_R = lin.contacts(contacts(rng, lin, 40, pred))
    assert len(lin.pairs(Mixture.empty(4), z, contact_R, 50.0).j) == 0
    none = lin.pairs(pred, z[:0], None if contact_R is None else contact_R[:0], 50.0)
    assert len(none.j) == 0 and none.n_contacts == 0
    for k in range(len(z)):
        one = slice(k, k + 1)
        R = None if contact_R is None else contact_R[one]
        got, want = lin.pairs(pred, z[one], R, 50.0), brute(lin, pred, z[one], R, 50.0)
        np.testing.assert_array_equal(got.j, want.j)
        np.testing.assert_allclose(got.log_likelihood, want.log_likelihood, rtol=1e-9, atol=0)


def test_the_azimuth_wrap_and_contacts_at_one_range():
    """Components and contacts either side of azimuth +-pi (and at 0 / 2 pi), all at one range: the pairs across
    the wrap are found, and only the contacts near each component are examined."""
    lin = gmphd.EKF(RADAR)
    az = np.pi - np.array([1e-3, 5e-4, 0.0, -5e-4, -1e-3, 3.0, 1.0])  # 0 rad in the middle
    az = np.where(az >= np.pi, az - 2 * np.pi, az)
    x = 10_000.0 * np.column_stack([np.sin(az), np.zeros_like(az), np.cos(az), np.zeros_like(az)])
    P = np.broadcast_to(np.diag([400.0, 100.0, 400.0, 100.0]), (len(az), 4, 4)).copy()
    pred = Mixture(np.ones(len(az)), x, P, np.arange(len(az)))
    ring = np.linspace(-np.pi, np.pi, 4001)[:-1]
    z = np.column_stack([np.full(ring.size + 3, 10_000.0), np.r_[ring, 2 * np.pi - 1e-4, np.pi - 1e-4, 1e-4]])
    got, want = lin.pairs(pred, z, None, 50.0), brute(lin, pred, z, None, 50.0)
    np.testing.assert_array_equal(got.j, want.j)
    np.testing.assert_array_equal(got.i, want.i)
    np.testing.assert_array_equal(got.nu, want.nu)
    across = got.i[got.j == 2]  # the component at azimuth pi pairs with contacts on both sides of it
    assert (z[across, 1] < 0).any() and (z[across, 1] > 0).any()
    centre = lin.predict_measurement(pred.means, pred.covariances).z
    j, _ = gmphd.candidates(gmphd.Contacts(z, 2 * np.pi), centre, np.full((len(az), 2), [90.0, 0.03]))
    assert len(j) < 0.01 * len(az) * len(z)  # a range window alone would take every contact of the ring


def test_wide_windows_and_wrapped_contacts_of_candidates():
    """`candidates` alone against its definition: windows wider than half the period take every azimuth; contacts
    given anywhere on the circle (beyond [-pi, pi)) wrap."""
    rng = np.random.default_rng(11)
    z = np.column_stack([rng.uniform(0, 1000, 400), rng.uniform(-10.0, 10.0, 400)])
    centre = np.column_stack([rng.uniform(0, 1000, 50), rng.uniform(-4.0, 4.0, 50)])
    for half_1, period in ((10.0 ** rng.uniform(-2, 0.7, 50), 2 * np.pi), (rng.uniform(1.0, 3.0, 50), 2 * np.pi),
                           (10.0 ** rng.uniform(-2, 0.7, 50), 0.0)):  # the second: two or three rows a period
        half = np.column_stack([rng.uniform(1, 300, 50), half_1])
        j, i = gmphd.candidates(gmphd.Contacts(z, period), centre, half)
        d1 = z[None, :, 1] - centre[:, None, 1]
        if period:
            d1 = (d1 + np.pi) % period - np.pi
        inside = (np.abs(z[None, :, 0] - centre[:, None, 0]) <= half[:, None, 0]) & (np.abs(d1) <= half[:, None, 1])
        got = set(zip(j.tolist(), i.tolist()))
        assert len(got) == len(j)  # each pair once
        want = set(zip(*np.nonzero(inside)))
        edge = np.abs(np.abs(d1) - half[:, None, 1]) < 1e-6  # within the margin of the window's edge: either way
        assert want - got == set() and not {(a, b) for a, b in got - want if not edge[a, b]}
