"""PMBM tracker: the single-target filter, the exact posterior of the global hypotheses, the bounds."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import BoundWarning, ConfigError
from nnda.filters.imm import IMM
from nnda.tracking.output import TrackStatus
from nnda.tracking.pmbm import PMBMTracker, _n_scan_agrees
from nnda.tracking.registry import make_tracker


def test_one_target_without_clutter_is_the_imm_run_on_its_contacts():
    """P_D 1, no clutter: once confirmed, the reported state is the IMM's two-point start and updates on
    the same contacts (relative 1e-9), one track, confirmed within a few scans."""
    sensor = Sensor(pd=1.0, clutter=Clutter(law="none"))
    target = Target(name="t", x_m=4_000.0, y_m=12_000.0, heading_deg=70.0, speed_m_s=180.0,
                    segments=[Segment(duration_s=30.0), Segment(duration_s=30.0, normal_accel=2.0)])
    ds = generate(Scenario(name="one", duration_s=60.0, targets=[target], sensors=(sensor,)), seed=7)
    tracker = make_tracker("pmbm", sensor, {"pd": 1.0, "clutter_density": 1e-8, "gate": 30.0})
    imm = IMM.for_sensor(sensor)
    scans = list(ds.scans())
    assert all(len(s.measurements) == 1 for s in scans)
    state, last, confirmed = None, None, 0
    for scan in scans:
        out = tracker.step(scan)
        z = np.asarray(scan.measurements, float)
        if last is None:
            last = (imm.measurement.cartesian(z), scan.time)
            continue
        if state is None:
            p2, cov2 = imm.measurement.position(z)
            state = imm.start(last[0], p2, cov2, scan.time - last[1])
        else:
            state = imm.update(imm.predict(state, scan.time - last[1]), z)
        last = (None, scan.time)
        x, P = imm.estimate(state)
        assert len(out) == 1 and out.contact.tolist() == [0]
        if out.status[0] == TrackStatus.CONFIRMED:
            confirmed += 1
            np.testing.assert_allclose(out.state, x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(out.covariance, P, rtol=1e-9, atol=1e-9)
    assert confirmed >= len(scans) - 4


def fixes(points: list[tuple[float, float]]) -> np.ndarray:
    return np.array(points, float)


#: two targets 150 m apart flying east at 100 m/s, seen by a position sensor (50 m noise): scans 1-2 open the
#: tracks, scans 3-4 are ambiguous (every contact in every gate: the gate is unbounded here)
TWO = [fixes([(10_000.0, 10_000.0), (10_000.0, 10_150.0)]),
       fixes([(10_210.0, 10_010.0), (10_190.0, 10_140.0)]),
       fixes([(10_420.0, 10_060.0), (10_380.0, 10_110.0)]),
       fixes([(10_610.0, 10_090.0), (10_600.0, 10_070.0), (10_590.0, 10_400.0)])]


def enumerate_posterior(tracker: PMBMTracker, scans: list[Scan]) -> dict[tuple, float]:
    """The exact posterior weights after ``scans``, from the tracker's mixture now, by enumerating every data
    association of every scan for every global hypothesis: per Bernoulli present, r -> p_S r, then a miss
    (weight 1 - r P_D, r -> r (1 - P_D) / (1 - r P_D)) or one contact no other Bernoulli takes (weight
    r P_D l(z) / lambda_c(z), r -> 1, the IMM updated); a contact left over weighs 1 (lambda_c relative).
    Keyed by the contacts (or -1) of each live label over ``scans``, None for an absent Bernoulli."""
    cfg, imm, sth = tracker.config, tracker.filter, tracker.sth
    out = {}
    for h, log_w in enumerate(tracker.log_w):
        present = [(i, s) for i, s in enumerate(tracker.hyp[h]) if s >= 0]
        branches = [(log_w, {i: (sth.tracks.filt.take([s]), sth.tracks.t2[s], sth.r[s], ()) for i, s in present})]
        for scan in scans:
            z = np.asarray(scan.measurements, float)
            lam = cfg.clutter_density * imm.measurement.area_jacobian(z)
            grown = []
            for w, bern in branches:
                keys = list(bern)
                for pick in itertools.product(*[[-1, *range(len(z))] for _ in keys]):
                    used = [c for c in pick if c >= 0]
                    if len(used) != len(set(used)):
                        continue
                    nw, nb = w, {}
                    for i, c in zip(keys, pick):
                        filt, t2, r, seq = bern[i]
                        r = cfg.survival_probability * r
                        if c < 0:
                            nw += math.log1p(-r * cfg.pd)
                            nb[i] = (filt, t2, r * (1 - cfg.pd) / (1 - r * cfg.pd), (*seq, -1))
                        else:
                            pred = imm.predict(filt, scan.time - t2)
                            ll = imm.pair_log_likelihood(pred, np.array([0]), z[c:c + 1])[0]
                            nw += math.log(r * cfg.pd) + ll - math.log(lam[c])
                            nb[i] = (imm.update(pred, z[c:c + 1]), scan.time, 1.0, (*seq, c))
                    grown.append((nw, nb))
            branches = grown
        for w, bern in branches:
            key = tuple(bern[i][3] if i in bern else None for i in range(len(tracker.labels)))
            out[key] = np.logaddexp(out.get(key, -np.inf), w)
    total = np.logaddexp.reduce(list(out.values()))
    return {k: math.exp(v - total) for k, v in out.items()}


def test_two_targets_match_the_enumerated_posterior():
    """Unlimited budget (no pruning, every pair gated): the tracker's global hypotheses and weights after two
    ambiguous scans equal the exact enumeration from its mixture after the births (1e-9)."""
    sensor = Sensor(kind="position", sigma_position_m=50.0, clutter=Clutter(law="none"))
    cfg = {"clutter_density": 2e-8, "gate": 1e9, "max_global_hypotheses": 10**9, "n_scan": 10,
           "min_existence": 0.0, "min_hypothesis_weight": 0.0}
    tracker = make_tracker("pmbm", sensor, cfg)
    scans = [Scan(k + 1, 2.0 * (k + 1), z) for k, z in enumerate(TWO)]
    tracker.step(scans[0])
    tracker.step(scans[1])
    assert len(tracker.labels) >= 2
    want = enumerate_posterior(tracker, scans[2:])
    for scan in scans[2:]:
        tracker.step(scan)
    assert len(tracker.labels) == len(next(iter(want))), "a Bernoulli was born or lost in the ambiguous scans"
    got = {}
    for row, log_w in zip(tracker.hyp, tracker.log_w):
        key = tuple(None if s < 0 else tuple(tracker.sth.hist[s, -2:].tolist()) for s in row)
        got[key] = math.exp(log_w)
    assert len(want) > 100 and set(got) == set(want)
    for key, w in want.items():
        assert got[key] == pytest.approx(w, rel=1e-9, abs=1e-15)


def test_the_hypothesis_cap_is_respected_and_warned_once():
    sensor = Sensor(kind="position", sigma_position_m=50.0, clutter=Clutter(law="none"))
    tracker = make_tracker("pmbm", sensor, {"clutter_density": 2e-8, "gate": 1e9, "max_global_hypotheses": 5,
                                            "min_hypothesis_weight": 0.0})
    with pytest.warns(BoundWarning, match=r"config field max_global_hypotheses") as caught:
        for k, z in enumerate(TWO):
            tracker.step(Scan(k + 1, 2.0 * (k + 1), z))
            assert len(tracker.log_w) <= 5
    assert sum("max_global_hypotheses" in str(w.message) for w in caught) == 1
    assert tracker.n_capped >= 1 and math.isclose(np.exp(tracker.log_w).sum(), 1.0)


@pytest.mark.parametrize("field, value", [("pd", 0.0), ("pd", 1.5), ("survival_probability", 1.0),
                                          ("birth_rate", -1.0), ("max_global_hypotheses", 0), ("n_scan", 0),
                                          ("existence_threshold", 1.0), ("gate", 0.0), ("clutter_density", 0.0),
                                          ("min_hypothesis_weight", 1.0), ("bogus", 1)])
def test_bad_config_values_are_refused_by_name(field, value):
    with pytest.raises(ConfigError, match=field):
        make_tracker("pmbm", Sensor(), {field: value})


def test_pruning_before_confirmation_is_refused():
    with pytest.raises(ConfigError, match="min_existence = 0.5 must be below existence_threshold = 0.4"):
        make_tracker("pmbm", Sensor(), {"min_existence": 0.5, "existence_threshold": 0.4})


def test_n_scan_pruning_decides_the_oldest_scan_only_where_it_is_known():
    """Three Bernoullis, the best hypothesis first. A hypothesis is pruned when a Bernoulli present in both
    chose differently n_scan scans back, or when it gives a contact the best one gave to another Bernoulli;
    a Bernoulli absent from the best (pruned there for its low existence) decides nothing."""
    hyp = np.array([[0, -1, -1],    # best: Bernoulli 0 took contact 5, 1 and 2 absent
                    [2, 3, -1],     # 0 missed there: a different choice
                    [4, 5, 6],      # agrees; 1 (missed) and 2 (took contact 8) are present here only
                    [-1, 8, -1],    # 1 took contact 5, which the best gave to 0
                    [9, -1, -1]])   # agrees
    oldest = np.array([[5, -1, -1], [-1, -1, -1], [5, -1, 8], [-1, 5, -1], [5, -1, -1]])
    np.testing.assert_array_equal(_n_scan_agrees(hyp, oldest, 0), [True, False, True, False, True])
