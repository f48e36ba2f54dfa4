"""GOSPA and OSPA, with their parts, against brute force over every assignment on small sets; the per-scan
and per-run measures of a tracker run against the same references."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.study.gospa import Ospa, gospa, ospa, ospa_parts
from nnda.study.metrics import run_metrics
from nnda.tracking.output import TrackStatus as S
from nnda.tracking.registry import make_tracker
from tolerances import RTOL


def brute_gospa(x: np.ndarray, y: np.ndarray, c: float, p: float) -> float:
    """Definition: min over partial assignments of sum d^p + c^p/2 (|X| + |Y| - 2|gamma|)."""
    best = np.inf
    m, n = len(x), len(y)
    for k in range(min(m, n) + 1):
        for rows in itertools.combinations(range(m), k):
            for cols in itertools.permutations(range(n), k):
                cost = sum(min(np.linalg.norm(x[i] - y[j]), c) ** p for i, j in zip(rows, cols))
                best = min(best, cost + c**p / 2 * (m + n - 2 * k))
    return best ** (1 / p)


def brute_ospa_parts(x, y, c, p) -> tuple[float, float, float]:
    """Definition: (OSPA, localisation, cardinality) from the best of every injection of the smaller set."""
    if len(x) > len(y):
        x, y = y, x
    m, n = len(x), len(y)
    if n == 0:
        return 0.0, 0.0, 0.0
    best = min(sum(min(np.linalg.norm(x[i] - y[j]), c) ** p for i, j in enumerate(perm))
               for perm in itertools.permutations(range(n), m))
    return (((best + c**p * (n - m)) / n) ** (1 / p), (best / n) ** (1 / p), (c**p * (n - m) / n) ** (1 / p))


def brute_ospa(x, y, c, p):
    return brute_ospa_parts(x, y, c, p)[0]


def brute_gospa_parts(x, y, c, p) -> tuple[float, float, float]:
    """(localisation, missed, false) of the best partial assignment of pairs closer than c (alpha = 2)."""
    best = (np.inf, 0.0, 0.0, 0.0)
    m, n = len(x), len(y)
    for k in range(min(m, n) + 1):
        for rows in itertools.combinations(range(m), k):
            for cols in itertools.permutations(range(n), k):
                d = [np.linalg.norm(x[i] - y[j]) for i, j in zip(rows, cols)]
                if any(v >= c for v in d):
                    continue
                loc = sum(v**p for v in d)
                missed, false = c**p / 2 * (m - k), c**p / 2 * (n - k)
                if loc + missed + false < best[0]:
                    best = (loc + missed + false, loc, missed, false)
    return best[1:]


points = arrays(np.float64, st.tuples(st.integers(0, 4), st.just(2)), elements=st.floats(0, 3000))


@settings(max_examples=120, deadline=None)
@given(x=points, y=points, c=st.sampled_from([200.0, 500.0, 1000.0]), p=st.sampled_from([1.0, 2.0]))
def test_gospa_and_ospa_equal_brute_force(x, y, c, p):
    g = gospa(x, y, c, p)
    assert g.distance == pytest.approx(brute_gospa(x, y, c, p), rel=1e-9, abs=1e-9)
    assert g.distance**p == pytest.approx(g.localisation + g.missed + g.false, rel=1e-9, abs=1e-9)
    assert ospa(x, y, c, p) == pytest.approx(brute_ospa(x, y, c, p), rel=1e-9, abs=1e-9)
    o = ospa_parts(x, y, c, p)
    assert (o.distance, o.localisation, o.cardinality) == pytest.approx(brute_ospa_parts(x, y, c, p), rel=1e-9,
                                                                        abs=1e-9)
    assert o.distance == ospa(x, y, c, p)
    assert o.distance**p == pytest.approx(o.localisation**p + o.cardinality**p, rel=1e-9, abs=1e-9)


def test_gospa_parts_equal_brute_force_on_random_sets():
    rng = np.random.default_rng(11)  # continuous positions: no two partial assignments tie
    for _ in range(150):
        x, y = (rng.uniform(0, 3000, (rng.integers(0, 5), 2)) for _ in range(2))
        c, p = rng.choice([200.0, 500.0, 1000.0]), rng.choice([1.0, 2.0])
        g = gospa(x, y, c, p)
        assert (g.localisation, g.missed, g.false) == pytest.approx(brute_gospa_parts(x, y, c, p), rel=1e-9,
                                                                     abs=1e-9)


def test_gospa_parts_on_a_hand_made_case():
    truth = np.array([[0.0, 0.0], [10_000.0, 0.0], [0.0, 10_000.0]])
    est = np.array([[30.0, 40.0], [10_000.0, 2_000.0], [-5_000.0, 0.0], [-6_000.0, 0.0]])
    g = gospa(truth, est, c=1000.0)
    # one pair at 50 m; truth 2 is 2 km from its nearest estimate (beyond c): missed; truth 3 missed
    assert (g.n_missed, g.n_false) == (2, 3)
    assert g.localisation == pytest.approx(2500.0)
    assert g.missed == pytest.approx(2 * 1000.0**2 / 2) and g.false == pytest.approx(3 * 1000.0**2 / 2)
    assert gospa(np.empty((0, 2)), np.empty((0, 2)), 1000.0).distance == 0.0
    assert ospa(truth, np.empty((0, 2)), 1000.0) == 1000.0
    assert ospa_parts(truth, np.empty((0, 2)), 1000.0) == Ospa(1000.0, 0.0, 1000.0)
    assert ospa_parts(np.empty((0, 2)), np.empty((0, 2)), 1000.0) == Ospa(0.0, 0.0, 0.0)
    # 4 estimates, 3 truths: pairs at 50 m, 1000 m (cut: 2 km) and 1000 m (cut: 5 km), one estimate left over
    o = ospa_parts(truth, est, 1000.0)
    assert o.localisation == pytest.approx(((50.0**2 + 2 * 1000.0**2) / 4) ** 0.5)
    assert o.cardinality == pytest.approx((1000.0**2 / 4) ** 0.5)


def test_bad_input():
    with pytest.raises(ValueError, match=r"truth: expected an \(n, 2\) array"):
        gospa(np.zeros((3, 3)), np.zeros((1, 2)), 100.0)
    with pytest.raises(ValueError, match="estimates: positions must be finite"):
        gospa(np.zeros((1, 2)), np.array([[np.nan, 0.0]]), 100.0)


@pytest.fixture(scope="module")
def phd_run():
    """A CPHD on S4 (4 targets, clutter): its outputs and every measure of the run."""
    ds = generate(PRESETS["S4"], seed=2)
    tracker = make_tracker("cphd", ds.scenario.sensors)
    outputs = [tracker.step(scan) for scan in ds.scans()]
    return ds, outputs, run_metrics(ds, outputs, cutoff_m=1000.0)


def test_the_set_measures_per_scan_and_per_run_equal_brute_force(phd_run):
    ds, outputs, m = phd_run
    t = ds.truth
    parts = {"gospa": [], "gospa_localisation": [], "gospa_missed": [], "gospa_false": [], "ospa": [],
             "ospa_localisation": [], "ospa_cardinality": []}
    for o in outputs:
        truth = np.column_stack([t.x[t.scan == o.scan], t.y[t.scan == o.scan]])
        est = o.state[o.status == S.CONFIRMED][:, [0, 2]]
        loc, missed, false = brute_gospa_parts(truth, est, 1000.0, 2.0)
        for key, v in zip(parts, ((loc + missed + false) ** 0.5, loc, missed, false,
                                  *brute_ospa_parts(truth, est, 1000.0, 2.0))):
            parts[key].append(v)
    assert max(len(o) for o in outputs) >= 4 and m.ospa_cardinality.max() > 0  # some scans miscount
    for key, expected in parts.items():
        np.testing.assert_allclose(m.series[key], expected, rtol=RTOL, atol=1e-9, err_msg=key)
        assert m.values[key] == pytest.approx(np.mean(expected), rel=RTOL), key


def test_the_close_pair_path_equals_brute_force(monkeypatch):
    """Above `DENSE_MAX_PAIRS` (forced here to 0) GOSPA and OSPA solve only the pairs closer than c: the same
    values as the definitions."""
    import nnda.study.gospa as module

    monkeypatch.setattr(module, "DENSE_MAX_PAIRS", 0)
    rng = np.random.default_rng(5)
    for _ in range(150):
        x, y = (rng.uniform(0, 3000, (rng.integers(0, 5), 2)) for _ in range(2))
        c, p = rng.choice([200.0, 500.0, 1000.0]), rng.choice([1.0, 2.0])
        g = gospa(x, y, c, p)
        assert g.distance == pytest.approx(brute_gospa(x, y, c, p), rel=1e-9, abs=1e-9)
        assert (g.localisation, g.missed, g.false) == pytest.approx(brute_gospa_parts(x, y, c, p), rel=1e-9,
                                                                     abs=1e-9)
        o = ospa_parts(x, y, c, p)
        assert (o.distance, o.localisation, o.cardinality) == pytest.approx(brute_ospa_parts(x, y, c, p),
                                                                            rel=1e-9, abs=1e-9)
    same = np.array([[0.0, 0.0], [0.0, 0.0]])  # coincident points: distance 0 pairs are close pairs too
    assert gospa(same, same, 100.0).distance == 0.0 and ospa(same, same, 100.0) == 0.0


def test_the_close_pair_path_equals_the_dense_one_on_hundreds_of_targets(monkeypatch):
    """2,000 targets against 1,900 estimates (90% of them near a target) and 200 far ones: the two paths agree
    to 1e-9 and the close one runs by default at this size."""
    import nnda.study.gospa as module

    rng = np.random.default_rng(2)
    truth = rng.uniform(-200e3, 200e3, (2_000, 2))
    est = np.concatenate([truth[:1_900] + rng.normal(0, 400, (1_900, 2)), rng.uniform(-200e3, 200e3, (200, 2))])
    assert truth.shape[0] * est.shape[0] > module.DENSE_MAX_PAIRS
    close, close_ospa = gospa(truth, est, 1_000.0), ospa_parts(truth, est, 1_000.0)
    monkeypatch.setattr(module, "DENSE_MAX_PAIRS", np.inf)
    dense, dense_ospa = gospa(truth, est, 1_000.0), ospa_parts(truth, est, 1_000.0)
    assert (close.n_missed, close.n_false) == (dense.n_missed, dense.n_false)
    for a, b in ((close.distance, dense.distance), (close.localisation, dense.localisation),
                 (close_ospa.distance, dense_ospa.distance), (close_ospa.localisation, dense_ospa.localisation)):
        assert a == pytest.approx(b, rel=RTOL)
