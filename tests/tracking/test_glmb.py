"""δ-GLMB and LMB trackers: the single-target filter, the exact posterior of the hypotheses, LMB against GLMB,
the config, the seed and the hypothesis cap."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tests.tracking import labelled_helpers as lab

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import ConfigError
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker


@pytest.mark.parametrize("name", ["glmb", "lmb"])
def test_one_target_without_clutter_is_the_imm_run_on_its_contacts(name):
    """P_D 1, no clutter: once confirmed, the reported state is the IMM's two-point start and updates on the
    same contacts (1e-9); one track, confirmed within a few scans."""
    sensor, scans = lab.one_target()
    tracker = make_tracker(name, sensor, {"pd": 1.0, "clutter_density": 1e-8, "gate": 30.0})
    confirmed = 0
    for scan, start, estimate in lab.imm_on_contacts(sensor, scans):
        out = tracker.step(scan)
        if start:
            assert out.status.tolist() == [TrackStatus.PRELIMINARY]  # the birth, waiting for the next scan
        elif estimate is not None:
            assert len(out) == 1 and out.contact.tolist() == [0]
            confirmed += lab.confirmed_as_the_imm(out, *estimate)
    assert confirmed >= len(scans) - 4


def enumerate_posterior(tracker, scans: list[Scan]) -> dict[tuple, float]:
    """The exact δ-GLMB posterior after ``scans`` from the tracker's waiting births (its mixture is empty), by
    enumerating every assignment of every scan: per track present with existence e, death (weight 1 - p_S e,
    the label absent), a miss (p_S e (1 - P_D)) or one contact no other track takes (p_S e P_D l(z) /
    lambda_c(z), the IMM updated); a contact left over weighs 1 (lambda_c relative); a track present
    afterwards has e = 1; two births of one contact are not both present. Keyed by each label's contacts (or
    -1) over ``scans``, None for an absent label."""
    cfg, imm, born = tracker.config, tracker.filter, tracker.born
    assert tracker.trk is None and born is not None
    n = len(born)

    def grow(w, tracks, scan, z, lam):
        keys = list(tracks)
        preds = {i: imm.predict(tracks[i][0], scan.time - tracks[i][1]) for i in keys}
        for pick in lab.associations(len(keys), len(z), (-2, -1)):
            births = [born.group[i] for i, c in zip(keys, pick) if c != -2 and tracks[i][3] == ()]
            if len(births) != len(set(births)):
                continue
            nw, nt = w, {}
            for i, c in zip(keys, pick):
                filt, t2, e, seq = tracks[i]
                alive = cfg.survival_probability * e
                if c == -2:
                    nw += math.log1p(-alive)
                elif c == -1:
                    nw += math.log(alive * (1 - cfg.pd))
                    nt[i] = (filt, t2, 1.0, (*seq, -1))
                else:
                    ll = imm.pair_log_likelihood(preds[i], np.array([0]), z[c:c + 1])[0]
                    nw += math.log(alive * cfg.pd) + ll - math.log(lam[c])
                    nt[i] = (imm.update(preds[i], z[c:c + 1]), scan.time, 1.0, (*seq, c))
            yield nw, nt

    start = {i: (born.tracks.filt.take([i]), born.tracks.t2[i], born.r[i], ()) for i in range(n)}
    branches = lab.enumerated(tracker, [(0.0, start)], scans, grow)
    return lab.posterior(branches, n)


EXACT = {"clutter_density": 2e-8, "gate": 1e9, "max_hypotheses": 10**9, "n_scan": 10, "sampler": "exhaustive",
         "min_hypothesis_weight": 0.0, "admission_existence": 0.0}


def test_two_targets_match_the_enumerated_posterior():
    """Unlimited budget, every assignment enumerated: the hypotheses and weights after the births' two
    ambiguous scans equal the exact enumeration (1e-9)."""
    tracker = make_tracker("glmb", lab.POSITION, EXACT)
    scans = lab.two_scans()
    tracker.step(scans[0])
    tracker.step(scans[1])
    labels = tracker.born.tracks.track_id.tolist()
    assert len(labels) == 4 and sorted(tracker.born.group.tolist()) == [0, 0, 1, 1]
    want = enumerate_posterior(tracker, scans[2:])
    for scan in scans[2:]:
        tracker.step(scan)
    assert tracker.born is None and tracker.labels.tolist() == labels
    lab.check_the_posterior(tracker, want)


def test_the_sampler_finds_the_exact_update_when_it_has_draws_enough():
    """The Gibbs sampler with many draws finds every hypothesis of non-negligible weight of the exact update."""
    exact = make_tracker("glmb", lab.POSITION, EXACT)
    sampled = make_tracker("glmb", lab.POSITION, {**EXACT, "sampler": "gibbs", "gibbs_samples": 3_000})
    for scan in lab.two_scans()[:3]:
        exact.step(scan)
        sampled.step(scan)
    weight = lambda t: {tuple(None if s < 0 else tuple(t.trk.hist[s]) for s in row): math.exp(w)  # noqa: E731
                        for row, w in zip(t.hyp, t.log_w)}
    a, b = weight(exact), weight(sampled)
    heavy = {k for k, w in a.items() if w > 1e-3}
    assert heavy and heavy <= set(b)
    norm = sum(a[k] for k in b)  # the sampled mixture is the exact one restricted to what it found
    for k in heavy:
        assert b[k] == pytest.approx(a[k] / norm, rel=1e-9)


def test_lmb_equals_glmb_where_the_targets_never_share_a_gate():
    """Two targets 20 km apart, no clutter: the LMB's collapse loses nothing the report shows."""
    sensor = Sensor(pd=0.9, clutter=Clutter(law="none"))
    targets = [Target(name="a", x_m=-10_000.0, y_m=12_000.0, heading_deg=90.0, speed_m_s=150.0,
                      segments=[Segment(duration_s=60.0)]),
               Target(name="b", x_m=10_000.0, y_m=-8_000.0, heading_deg=200.0, speed_m_s=120.0,
                      segments=[Segment(duration_s=30.0), Segment(duration_s=30.0, normal_accel=3.0)])]
    ds = generate(Scenario(name="apart", duration_s=60.0, targets=targets, sensors=(sensor,)), seed=3)
    params = {"clutter_density": 1e-8}
    glmb, lmb = make_tracker("glmb", sensor, params), make_tracker("lmb", sensor, params)
    confirmed = 0
    for scan in ds.scans():
        a, b = glmb.step(scan), lmb.step(scan)
        np.testing.assert_array_equal(a.track_id, b.track_id)
        np.testing.assert_array_equal(a.status, b.status)
        np.testing.assert_array_equal(a.contact, b.contact)
        np.testing.assert_allclose(a.state, b.state, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-9)
        confirmed = max(confirmed, int((a.status == TrackStatus.CONFIRMED).sum()))
    assert confirmed == 2 and len(lmb.log_w) == 1


@pytest.mark.parametrize("name", ["glmb", "lmb"])
@pytest.mark.parametrize("field, value", [("pd", 0.0), ("pd", 1.5), ("survival_probability", 1.0),
                                          ("birth_rate", -1.0), ("max_hypotheses", 0), ("gibbs_samples", 0),
                                          ("n_scan", 0), ("sampler", "murty"), ("seed", -1),
                                          ("existence_threshold", 1.0), ("gate", 0.0), ("clutter_density", 0.0),
                                          ("min_hypothesis_weight", 1.0), ("admission_existence", 1.0),
                                          ("min_tentative_existence", -0.1), ("bogus", 1)])
def test_bad_config_values_are_refused_by_name(name, field, value):
    with pytest.raises(ConfigError, match=field):
        make_tracker(name, Sensor(), {field: value})


def test_lmb_pruning_before_confirmation_is_refused():
    with pytest.raises(ConfigError, match="min_existence = 0.5 must be below existence_threshold = 0.4"):
        make_tracker("lmb", Sensor(), {"min_existence": 0.5, "existence_threshold": 0.4})
    with pytest.raises(ConfigError, match="min_existence"):
        make_tracker("glmb", Sensor(), {"min_existence": 0.1})


@pytest.mark.parametrize("name", ["glmb", "lmb"])
def test_dropping_a_tentative_label_before_its_admission_is_refused(name):
    with pytest.raises(ConfigError, match="min_tentative_existence = 0.2 must be below admission_existence = 0.1"):
        make_tracker(name, Sensor(), {"min_tentative_existence": 0.2, "admission_existence": 0.1})
    make_tracker(name, Sensor(), {"min_tentative_existence": 0.2, "admission_existence": 0.0})  # no tentatives


@pytest.mark.parametrize("name", ["glmb", "lmb"])
def test_the_seed_fixes_the_samples(name):
    """The same seed gives the same run (the labels' existence too); another seed draws other samples."""
    ds = generate(PRESETS["S3"].model_copy(update={"duration_s": 40.0}), seed=2)
    runs = []
    for seed in (5, 5, 6):
        # every birth in the hypotheses (none waits as a tentative label), so that the sampler decides something
        tracker = make_tracker(name, ds.scenario.sensor, {"seed": seed, "admission_existence": 0.0})
        outs, mixtures = [], []
        for scan in ds.scans():
            outs.append(tracker.step(scan))
            mixtures.append(tracker.existence())
        runs.append((outs, mixtures))
    (a, ma), (b, mb), (_, mc) = runs
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.track_id, y.track_id)
        np.testing.assert_array_equal(x.state, y.state)
    assert all(np.array_equal(p, q) for p, q in zip(ma, mb))
    assert not all(p.shape == q.shape and np.array_equal(p, q) for p, q in zip(ma, mc))


def test_the_hypothesis_cap_is_respected_and_warned_once():
    lab.check_the_cap("glmb", "max_hypotheses", admission_existence=0.0)  # every birth in the hypotheses


def test_a_tentative_label_is_the_bernoulli_updated_alone():
    """Births below ``admission_existence`` wait as tentative labels, each updated alone on the free contacts:
    existence a (1 - P_D + sum_z P_D l(z) / lambda_c(z)) over that plus 1 - a (a = p_S r), the track its heaviest
    child; those reaching the admission level join the hypotheses at the next scan (1e-9)."""
    tracker = make_tracker("glmb", lab.POSITION, {"clutter_density": 2e-8, "gate": 1e9})
    cfg, imm, scans = tracker.config, tracker.filter, lab.two_scans()
    tracker.step(scans[0])
    tracker.step(scans[1])
    born, scan = tracker.born, scans[2]
    assert len(born) == 4 and (born.r < cfg.admission_existence).all()
    z = np.asarray(scan.measurements, float)
    lam = cfg.clutter_density * imm.measurement.area_jacobian(z)
    want_r, want_j, want_x = [], [], []
    for i in range(len(born)):
        pred = imm.predict(born.tracks.filt.take([i]), scan.time - born.tracks.t2[i])
        ratio = [cfg.pd * math.exp(imm.pair_log_likelihood(pred, np.array([0]), z[j:j + 1])[0]) / lam[j]
                 for j in range(len(z))]
        a, total = cfg.survival_probability * born.r[i], 1 - cfg.pd + sum(ratio)
        want_r.append(a * total / (1 - a + a * total))
        want_j.append(int(np.argmax(ratio)))
        assert ratio[want_j[-1]] > 1 - cfg.pd
        want_x.append(imm.estimate(imm.update(pred, z[want_j[-1]:want_j[-1] + 1]))[0][0])
    tracker.step(scan)
    ready = tracker.born
    assert tracker.table is None and tracker.tentative is None and (ready.r >= cfg.admission_existence).all()
    np.testing.assert_array_equal(ready.tracks.track_id, born.tracks.track_id)
    np.testing.assert_array_equal(ready.contact, want_j)
    np.testing.assert_allclose(ready.r, want_r, rtol=1e-9)
    np.testing.assert_allclose(ready.x, want_x, rtol=1e-9, atol=1e-9)
    tracker.step(scans[3])
    assert tracker.born is None and set(tracker.labels.tolist()) <= set(born.tracks.track_id.tolist())


@pytest.mark.parametrize("name", ["glmb", "lmb"])
def test_targets_in_a_thousand_clutter_a_scan_are_confirmed(name):
    """The tentative labels let both targets in 1,000 clutter a scan be confirmed, no false track (with every
    birth in the hypotheses at once, admission_existence 0, none is confirmed: their existence stays near the
    births' ~1e-4 among hundreds of clutter births a scan)."""
    lab.check_dense_clutter(name)


@pytest.mark.parametrize("name", ["pmbm", "glmb", "lmb"])
def test_the_target_count_is_the_mixture_of_multi_bernoulli_counts(name):
    """After each scan the tracker's count record holds the mean and variance of the number of live labels,
    checked against the count distribution built by hand: per hypothesis the Poisson-binomial of its labels'
    existences convolved with the tentative labels', mixed by the hypotheses' weights."""
    params = {"clutter_density": 2e-8, "gate": 1e9}
    tracker = make_tracker(name, lab.POSITION, params)
    for scan in lab.two_scans():
        out = tracker.step(scan)
        rows = [[tracker.table.r[s] for s in row if s >= 0] for row in tracker.hyp] if tracker.table is not None \
            else [[]]
        tentative = [] if tracker.tentative is None else list(tracker.tentative.r)
        p = np.zeros(len(tracker.labels) + len(tentative) + 1)
        for w, r in zip(np.exp(tracker.log_w), rows):
            dist = np.ones(1)
            for ri in [*r, *tentative]:
                dist = np.convolve(dist, [1.0 - ri, ri])
            p[:dist.size] += w * dist
        n = np.arange(p.size)
        count = tracker.cardinality
        assert (count.scan, count.time) == (scan.index, scan.time)
        assert count.extracted == int((out.status == TrackStatus.CONFIRMED).sum())
        assert math.isclose(count.mean, n @ p, rel_tol=1e-9, abs_tol=1e-12)
        assert math.isclose(count.variance, (n - n @ p) ** 2 @ p, rel_tol=1e-9, abs_tol=1e-12)
    assert count.mean > 1.5  # both targets counted by the last scan


@pytest.mark.parametrize("name", ["glmb", "lmb"])
def test_a_confirmed_label_is_left_out_while_its_existence_is_low_and_keeps_its_id(name):
    """The hypotheses where the target has ended stay beside those where it coasts (N-scan pruning constrains no
    absent label), so the label's existence falls with its misses: `labelled_helpers.gap_and_end`."""
    lab.gap_and_end(name, 0.5)


@pytest.mark.parametrize("name", ["glmb", "lmb"])
def test_a_contact_a_tentative_label_took_opens_no_birth(name):
    """In dense clutter no birth pairs a contact that a tentative label's child took in the same scan, also when
    the label falls below ``min_tentative_existence`` there and is dropped (as in pmbm)."""
    ds = lab.dense_clutter()
    tracker = make_tracker(name, ds.scenario.sensors, {})
    children, births = tracker._tentative_children, tracker._births
    seen = {"dropped": 0, "births": 0}

    def took(scan, g, used):
        kids, ready, contact = children(scan, g, used)
        kept = 0 if kids is None else int(np.count_nonzero(kids.hist[:, -1] >= 0))
        seen["dropped"] += int(np.count_nonzero(contact >= 0)) - kept
        seen["taken"] = contact[contact >= 0]
        return kids, ready, contact

    def born(scan, used, taken=None, live=0):
        new, contact = births(scan, used, taken, live)
        if contact is not None and taken is not None:
            seen["births"] += contact.size
            assert not np.isin(contact, seen["taken"]).any()
        return new, contact

    tracker._tentative_children, tracker._births = took, born
    for scan in ds.scans():
        tracker.step(scan)
    assert seen["dropped"] > 100 and seen["births"] > 1000
