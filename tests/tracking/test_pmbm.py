"""PMBM tracker: the single-target filter, the exact posterior of the global hypotheses, the bounds."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from tests.tracking import labelled_helpers as lab

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.errors import ConfigError
from nnda.tracking.labelled import n_scan_agrees
from nnda.tracking.output import TrackStatus
from nnda.tracking.pmbm import PMBMTracker
from nnda.tracking.pmbm_hypotheses import scan_hypotheses
from nnda.tracking.registry import make_tracker


def test_one_target_without_clutter_is_the_imm_run_on_its_contacts():
    """P_D 1, no clutter: once confirmed, the reported state is the IMM's two-point start and updates on
    the same contacts (relative 1e-9), one track, confirmed within a few scans."""
    sensor, scans = lab.one_target()
    tracker = make_tracker("pmbm", sensor, {"pd": 1.0, "clutter_density": 1e-8, "gate": 30.0})
    confirmed = 0
    for scan, _, estimate in lab.imm_on_contacts(sensor, scans):
        out = tracker.step(scan)
        if estimate is not None:
            assert len(out) == 1 and out.contact.tolist() == [0]
            confirmed += lab.confirmed_as_the_imm(out, *estimate)
    assert confirmed >= len(scans) - 4


def enumerate_posterior(tracker: PMBMTracker, scans: list[Scan]) -> dict[tuple, float]:
    """The exact posterior weights after ``scans``, from the tracker's mixture now, by enumerating every data
    association of every scan for every global hypothesis: per Bernoulli present, r -> p_S r, then a miss
    (weight 1 - r P_D, r -> r (1 - P_D) / (1 - r P_D)) or one contact no other Bernoulli takes (weight
    r P_D l(z) / lambda_c(z), r -> 1, the IMM updated); a contact left over weighs 1 (lambda_c relative).
    Keyed by the contacts (or -1) of each live label over ``scans``, None for an absent Bernoulli."""
    cfg, imm, sth = tracker.config, tracker.filter, tracker.sth

    def grow(w, bern, scan, z, lam):
        keys = list(bern)
        for pick in lab.associations(len(keys), len(z), (-1,)):
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
            yield nw, nb

    ends = []
    for h, log_w in enumerate(tracker.log_w):
        present = [(i, s) for i, s in enumerate(tracker.hyp[h]) if s >= 0]
        start = {i: (sth.tracks.filt.take([s]), sth.tracks.t2[s], sth.r[s], ()) for i, s in present}
        ends += lab.enumerated(tracker, [(log_w, start)], scans, grow)
    return lab.posterior(ends, len(tracker.labels))


def test_two_targets_match_the_enumerated_posterior():
    """Unlimited budget (no pruning, every pair gated): the tracker's global hypotheses and weights after two
    ambiguous scans equal the exact enumeration from its mixture after the births (1e-9)."""
    cfg = {"clutter_density": 2e-8, "gate": 1e9, "max_global_hypotheses": 10**9, "n_scan": 10,
           "min_existence": 0.0, "min_hypothesis_weight": 0.0, "admission_existence": 0.0}
    tracker = make_tracker("pmbm", lab.POSITION, cfg)
    scans = lab.two_scans()
    tracker.step(scans[0])
    tracker.step(scans[1])
    assert len(tracker.labels) >= 2
    want = enumerate_posterior(tracker, scans[2:])
    for scan in scans[2:]:
        tracker.step(scan)
    assert len(tracker.labels) == len(next(iter(want))), "a Bernoulli was born or lost in the ambiguous scans"
    lab.check_the_posterior(tracker, want)


def test_the_hypothesis_cap_is_respected_and_warned_once():
    # every birth in the hypotheses, and every STH however unlikely, so that they outnumber the cap
    lab.check_the_cap("pmbm", "max_global_hypotheses", admission_existence=0.0, min_existence=0.0)


def test_targets_in_a_thousand_clutter_a_scan_are_confirmed():
    """The tentative labels keep the clutter's births out of the global hypotheses: both targets in 1,000 clutter
    a scan confirmed, no false track, hit rate 80 % or more (with every birth in the hypotheses,
    admission_existence 0, 75 %: hundreds of clutter Bernoullis share the hypothesis cap)."""
    lab.check_dense_clutter("pmbm")


def test_a_tentative_label_joins_the_hypotheses_with_its_existence():
    """Births below admission_existence are tentative labels (reported PRELIMINARY, in no global hypothesis);
    once one's existence reaches it, it joins the hypotheses leaving its contact free with that existence."""
    tracker = make_tracker("pmbm", lab.POSITION, {"clutter_density": 2e-8, "gate": 1e9})
    scans = lab.two_scans()
    tracker.step(scans[0])
    out = tracker.step(scans[1])
    tent = tracker.tentative
    assert tracker.table is None and len(tent) == 4 and (tent.r < tracker.config.admission_existence).all()
    assert sorted(out.track_id.tolist()) == sorted(tent.tracks.track_id.tolist())
    glmb = make_tracker("glmb", lab.POSITION, {"clutter_density": 2e-8, "gate": 1e9,
                                               "birth_rate": tracker.config.birth_rate})
    for scan in scans[:3]:
        glmb.step(scan)
    tracker.step(scans[2])  # the same tentative update as the GLMB's, then into the hypotheses
    assert tracker.tentative is None and tracker.labels.tolist() == glmb.born.tracks.track_id.tolist()
    np.testing.assert_allclose(tracker.table.r, glmb.born.r, rtol=1e-12)
    assert tracker.hyp.shape == (1, 4) and (tracker.hyp >= 0).all()  # no Bernoulli held a contact before them


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
    np.testing.assert_array_equal(n_scan_agrees(hyp, oldest, 0), [True, False, True, False, True])


def _agrees_by_sets(hyp, oldest, best):
    """`n_scan_agrees` in set operations: the reference the compiled pass is held to."""
    L = hyp.shape[1]
    both = (hyp >= 0) & (hyp[best] >= 0)
    same = ((oldest == oldest[best]) | ~both).all(axis=1)
    took = (hyp >= 0) & (oldest >= 0)
    mine = took[best]
    owned = np.unique(oldest[best][mine])
    pairs = np.unique(oldest[best][mine] * L + np.flatnonzero(mine))
    other = took & np.isin(oldest, owned) & ~np.isin(oldest * L + np.arange(L), pairs)
    return same & ~other.any(axis=1)


@pytest.mark.parametrize("seed", range(20))
def test_n_scan_pruning_equals_its_set_formulation(seed):
    rng = np.random.default_rng(seed)
    H, L = int(rng.integers(1, 12)), int(rng.integers(0, 8))
    hyp = np.where(rng.random((H, L)) < 0.7, rng.integers(0, 50, (H, L)), -1)
    oldest = rng.integers(-1, 6, (H, L))
    best = int(rng.integers(0, H))
    np.testing.assert_array_equal(n_scan_agrees(hyp, oldest, best), _agrees_by_sets(hyp, oldest, best))


@pytest.mark.parametrize("k", [1, 2, 5, 40])
def test_the_k_best_sums_over_many_clusters_are_the_enumerated_ones(k):
    """Eight Bernoullis each alone with its contacts (eight clusters, 1-3 contacts each, random gains): the k
    best associations are the k best of every combination (miss or one contact each), with their sums."""
    rng = np.random.default_rng(k)
    n_pairs = rng.integers(1, 4, 8)
    sth = np.repeat(np.arange(8), n_pairs)
    gain = rng.normal(0.0, 2.0, sth.size)
    got, log_gain, parent = scan_hypotheses(np.arange(8)[None, :], np.array([k]), sth, np.arange(sth.size),
                                            100 + np.arange(sth.size), gain)
    options = [[(s, 0.0)] + [(100 + p, gain[p]) for p in np.flatnonzero(sth == s)] for s in range(8)]
    every = sorted((-sum(g for _, g in pick), [c for c, _ in pick]) for pick in itertools.product(*options))
    assert parent.tolist() == [0] * min(k, len(every))
    np.testing.assert_allclose(log_gain, [-w for w, _ in every[:k]], rtol=1e-12)
    assert got.tolist() == [c for _, c in every[:k]]


def test_a_cluster_shared_by_global_hypotheses_is_ranked_once(monkeypatch):
    """Two global hypotheses holding the same two Bernoullis that share a contact (one cluster, ranked by
    Murty's method) and differing in a third: the cluster is ranked once, for the larger k, and each
    hypothesis's associations are those it has alone."""
    import nnda.tracking.pmbm_hypotheses as module

    calls = []
    ranked = module.k_best_assignments
    monkeypatch.setattr(module, "k_best_assignments", lambda cost, k: calls.append(k) or ranked(cost, k))
    hyp = np.array([[0, 1, 2], [0, 1, -1]])
    pairs = (np.array([0, 0, 1, 2]), np.array([0, 1, 1, 2]), np.array([10, 11, 12, 13]),
             np.array([1.0, 0.5, 2.0, -0.3]))
    ks = np.array([3, 5])
    both = scan_hypotheses(hyp, ks, *pairs)
    assert calls == [5]
    alone = [scan_hypotheses(hyp[h:h + 1], ks[h:h + 1], *pairs) for h in range(2)]
    np.testing.assert_array_equal(both[0], np.concatenate([a[0] for a in alone]))
    np.testing.assert_array_equal(both[1], np.concatenate([a[1] for a in alone]))
    assert both[2].tolist() == [0] * alone[0][1].size + [1] * alone[1][1].size



@pytest.mark.parametrize("report_existence", [0.5, 0.0])
def test_a_confirmed_track_is_left_out_while_its_existence_is_low_and_keeps_its_id(report_existence):
    """`labelled_helpers.gap_and_end`, the Bernoulli reported DELETED before the run ends; ``report_existence`` 0
    reports it through every miss, the gap's and the four after its target's end (min_existence 0.001 drops it
    at the fifth)."""
    shown, track, visible, after_end = lab.gap_and_end("pmbm", report_existence)
    assert shown[after_end[-1]].status.tolist() == [TrackStatus.DELETED]
    if not report_existence:
        assert lab.GAP <= visible and all(shown[k].status.tolist() == [TrackStatus.CONFIRMED] for k in lab.GAP)
        assert after_end[:4] == [lab.END + 1, lab.END + 2, lab.END + 3, lab.END + 4]
