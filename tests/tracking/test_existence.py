"""IPDA / JIPDA existence (lifecycle.confirmation = "existence")."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Sensor
from nnda.data.sensor import cart_to_polar
from nnda.errors import ConfigError
from nnda.tracking.jpda import given_existence
from nnda.tracking.lifecycle import (
    LifecycleConfig,
    advance_score,
    birth_log_odds,
    existence,
    jipda_log_ratio,
    predicted_log_odds,
)
from nnda.tracking.marginals import jpda_marginals, log_miss_weight
from nnda.tracking.output import CONFIRMED, DELETED, PRELIMINARY
from nnda.tracking.registry import make_tracker
from nnda.tracking.tracks import Tracks
from tolerances import RTOL

PD, GATE = 0.9, 9.21
PG = 1 - math.exp(-GATE / 2)
LOG_MISS = log_miss_weight(PD, GATE)


def _logit(p):
    return math.log(p) - math.log1p(-p)


def _one_track(rho_pred: float, ratios: list[float]):
    """JIPDA of one track of predicted existence rho_pred with contacts of likelihood ratios l / lambda:
    the association probabilities given existence, and the marginals."""
    log_ratio = np.log(PD * np.array(ratios))
    track = np.zeros(len(ratios), np.int64)
    m = jpda_marginals(track, np.arange(len(ratios)), jipda_log_ratio(log_ratio, LOG_MISS, np.full(len(ratios),
                       rho_pred)), 1, LOG_MISS, 10_000)
    return given_existence(np.array([_logit(rho_pred)]), m.beta, m.beta0, track, LOG_MISS), m


def test_prediction_is_the_markov_chain():
    np.testing.assert_allclose(existence(predicted_log_odds(np.array([_logit(0.7)]), 0.98)), [0.98 * 0.7], rtol=RTOL)


def test_no_contact_in_the_gate_lowers_existence_by_the_known_factor():
    rho = 0.6
    after = existence(_logit(rho) + LOG_MISS)  # what the framework adds for a track without gated contacts
    assert after == pytest.approx((1 - PD * PG) * rho / (1 - PD * PG * rho), rel=RTOL)
    assert after < rho


@pytest.mark.parametrize("ratios", [[3.0], [0.2, 5.0], [1e6]])
def test_one_track_given_existence_is_pda(ratios):
    """Given that the target exists, one track's association probabilities are PDA's, whatever rho."""
    (given, given0), _ = _one_track(0.6, ratios)
    r = PD * np.array(ratios)
    np.testing.assert_allclose(given, r / (1 - PD * PG + r.sum()), rtol=RTOL)
    assert given0[0] == pytest.approx((1 - PD * PG) / (1 - PD * PG + r.sum()), rel=RTOL)


def test_birth_odds_are_new_targets_against_clutter():
    """Prior odds of an initiator: P_D beta_NT / rho; ten times the clutter, a tenth of the odds."""
    rho = np.array([1e-8, 1e-7])
    odds = np.exp(birth_log_odds(PD, 2e-11, rho))
    np.testing.assert_allclose(odds, PD * 2e-11 / rho, rtol=RTOL)
    assert odds[1] == pytest.approx(odds[0] / 10, rel=RTOL)


def test_confirmation_is_reachable_under_the_survival_cap():
    """A certain track predicted by the survival s = 0.995 sits at odds 199; the default threshold c = 0.99
    (odds 99) is then met after any detection of ratio >= 1, while the old 0.9999 needed one above 50."""
    cfg = LifecycleConfig(confirmation="existence")
    capped = predicted_log_odds(np.array([700.0]), cfg.survival_probability)
    assert existence(capped)[0] == pytest.approx(cfg.survival_probability, rel=RTOL)
    for ratio in (1.0, 2.0, 60.0):
        after = capped + math.log(ratio)
        status = advance_score(np.array([PRELIMINARY], np.int8), after, after, cfg)
        assert status[0] == CONFIRMED, ratio
    assert _logit(0.9999) - capped[0] > math.log(50)


def test_preliminary_deletion_is_relative_to_the_best_existence():
    """A newborn's existence is tiny (far below existence_deletion), so it goes only when it falls
    ln(beta_p / (1 - alpha)) below its best: one miss is survived, two are not."""
    cfg = LifecycleConfig(confirmation="existence")
    birth = np.array([_logit(1e-4)])
    after_one = predicted_log_odds(birth, cfg.survival_probability) + LOG_MISS
    after_two = predicted_log_odds(after_one, cfg.survival_probability) + LOG_MISS
    prelim = np.array([PRELIMINARY], np.int8)  # the trackers' status dtype: no second compiled signature
    assert advance_score(prelim, after_one, birth, cfg)[0] == PRELIMINARY
    assert advance_score(prelim, after_two, birth, cfg)[0] == DELETED
    confirmed = np.array([CONFIRMED], np.int8)  # a confirmed track goes at existence_deletion itself
    assert advance_score(confirmed, np.array([_logit(0.011)]), np.array([9.0]), cfg)[0] == CONFIRMED
    assert advance_score(confirmed, np.array([_logit(0.009)]), np.array([9.0]), cfg)[0] == DELETED


def test_at_existence_one_jipda_is_jpda():
    rng = np.random.default_rng(3)
    track = np.array([0, 0, 1, 1, 2], np.int64)
    contact = np.array([0, 1, 1, 2, 2], np.int64)
    log_ratio = rng.normal(1.0, 1.0, 5)
    np.testing.assert_allclose(jipda_log_ratio(log_ratio, LOG_MISS, np.ones(5)), log_ratio, rtol=RTOL, atol=1e-12)
    m = jpda_marginals(track, contact, log_ratio, 3, LOG_MISS, 10_000)
    given, given0 = given_existence(np.full(3, 700.0), m.beta, m.beta0, track, LOG_MISS)
    np.testing.assert_allclose(given, m.beta, rtol=RTOL)
    np.testing.assert_allclose(given0, m.beta0, rtol=RTOL, atol=1e-12)


@pytest.mark.parametrize("kind", ["gnn", "jpda"])
def test_existence_rule_tracks_the_targets(kind):
    ds = generate(PRESETS["S4"], 0)
    tracker = make_tracker(kind, ds.scenario.sensors, {"lifecycle": {"confirmation": "existence"}})
    from nnda.study.metrics import run_metrics
    m = run_metrics(ds, [tracker.step(s) for s in ds.scans()])
    assert tracker.confirmation_rule == "existence"
    assert m.confirmed_tracks - m.false_tracks - m.track_breaks == 4 and m.false_tracks <= 1


def test_mht_refuses_the_existence_rule():
    with pytest.raises(ConfigError, match="existence"):
        make_tracker("mht", Sensor(), {"lifecycle": {"confirmation": "existence"}})


# ------------------------------------------------------------------ JIPDA with tentatives

def _jipda_with_confirmed_track():
    """A JIPDA tracker (fixed clutter density) holding one confirmed track of a target moving east at
    100 m/s, and the target's next contact (polar) at the track's prediction."""
    tracker = make_tracker("jpda", Sensor(), {"clutter_density": 1e-3, "lifecycle": {"confirmation": "existence"}})
    for k in range(1, 7):
        r, az = cart_to_polar(np.array([-5_000.0 + 200.0 * k]), np.array([12_000.0]))
        out = tracker.step(Scan(k, 2.0 * k, np.column_stack([r, az])))
    assert out.status.tolist() == [CONFIRMED]
    pred = tracker.filter.predict(tracker.tracks.filt, 14.0 - tracker.tracks.t2)
    return tracker, tracker.filter.combined_measurement(pred).z


def _step(tracker, tracks, z):
    tracker.tracks = replace(tracks)
    tracker.initiation.reset()  # no new tracks: the scan's contacts feed the tracks given
    tracker.step(Scan(7, 14.0, z))
    return tracker.tracks


def test_a_newborn_of_tiny_existence_updates_on_its_targets_contact():
    """JIPDA reports (and updates on) a contact against "no contact" given that the target exists: a
    preliminary track of existence 1e-6 whose target's contact lies at its prediction takes it. (Against the
    unconditional no-contact marginal, which holds "no target", it took nothing until its odds times the
    contact's ratio passed 1, and at 1,000 clutter per scan its gate grew for ~50 scans: GOSPA 1,009 m.)"""
    tracker, z = _jipda_with_confirmed_track()
    newborn = replace(tracker.tracks, status=np.array([PRELIMINARY], np.int8)).rescored(np.array([_logit(1e-6)]),
                                                                                       restart=True)
    pred_var = tracker.filter.predict(newborn.filt, 2.0).state.P[0, :, 0, 0]
    after = _step(tracker, newborn, z)
    assert after.t2[0] == 14.0  # the contact was used
    assert (after.filt.P[0, :, 0, 0] < 0.5 * pred_var).all()
    assert after.score[0] > _logit(1e-6)


def test_tentatives_sharing_the_contact_leave_the_confirmed_tracks_existence_as_ipda_alone():
    """A confirmed track and clutter-born tentatives (tiny existence, states about it) gate the same contact.
    The confirmed tracks' joint events are solved before the tentatives see the contacts (and the contacts
    they report are taken), so the tentatives cannot enter the confirmed track's events: its existence
    after the scan is what IPDA alone gives it, X = 0 up to rounding. A contact claimed by the confirmed
    track feeds no tentative."""
    tracker, z = _jipda_with_confirmed_track()
    alone = _step(tracker, tracker.tracks, z)
    tracker, z = _jipda_with_confirmed_track()
    one = tracker.tracks
    k = 5
    rng = np.random.default_rng(0)
    shift = np.zeros((k, one.filt.x.shape[1], one.filt.x.shape[2]))
    shift[:, :, 0] = rng.normal(0.0, 20.0, (k, 1))
    tentative = Tracks.concat([one] * k)
    tentative = replace(tentative, track_id=np.arange(100, 100 + k), status=np.full(k, PRELIMINARY, np.int8),
                        filt=type(one.filt)(tentative.filt.x + shift, tentative.filt.P, tentative.filt.mu)
                        ).rescored(np.full(k, _logit(1e-3)), restart=True)
    shared = _step(tracker, Tracks.concat([one, tentative]), z)
    assert shared.track_id[0] == one.track_id[0] and shared.status[0] == CONFIRMED
    assert existence(shared.score[0]) == pytest.approx(existence(alone.score[0]), rel=RTOL)
    assert (shared.t2[1:] < 14.0).all()  # the confirmed track reported the contact: no tentative used it


def test_the_existence_takes_ipdas_ratio_of_the_reported_contact():
    """A preliminary track with its target's contact at its prediction and clutter around it in its gate: its
    existence moves by ln(1 - P_D P_G + P_D l / lambda) of the contact it reports, not the soft sum over the
    gate (which walks up on vague clutter-born tracks at 5,000 per scan)."""
    tracker, z = _jipda_with_confirmed_track()
    rho0 = 1e-4
    tent = replace(tracker.tracks, status=np.array([PRELIMINARY], np.int8)).rescored(np.array([_logit(rho0)]),
                                                                                    restart=True)
    pred = tracker.filter.predict(tent.filt, 14.0 - tent.t2)
    mp = tracker.filter.combined_measurement(pred)
    step = np.linalg.cholesky(mp.S[0]) @ [np.sqrt(5.0), 0.0]
    contacts = np.vstack([z, z + step, z - step])
    before = predicted_log_odds(tent.score, tracker.config.lifecycle.survival_probability)[0]
    after = _step(tracker, tent, contacts)
    reported = tracker.filter.log_likelihood(pred, z)[0, 0]
    want = np.logaddexp(LOG_MISS, np.log(PD) + reported - np.log(1e-3))
    assert after.score[0] - before == pytest.approx(want, rel=RTOL)
