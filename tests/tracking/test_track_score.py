"""The track score (SPRT) rule of every contact tracker."""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.study.metrics import run_metrics
from nnda.tracking.lifecycle import LifecycleConfig, advance_score, rate_threshold, sprt_thresholds, start_score
from nnda.tracking.output import NO_CONTACT, TrackStatus
from nnda.tracking.registry import make_tracker
from tolerances import RTOL

SCORE = {"lifecycle": {"confirmation": "score"}}
KINDS = ["gnn", "jpda", "mht", "nn"]


def _params(kind, model_file, extra=None):
    params = {"model": str(model_file)} if kind == "nn" else {}
    return {**params, **(extra or {})}


@pytest.mark.parametrize("alpha, beta", [(1e-5, 1e-3), (1e-3, 0.1), (0.05, 0.05), (0.3, 0.6)])
def test_sprt_thresholds_are_walds_closed_forms(alpha, beta):
    lower, upper = sprt_thresholds(alpha, beta)
    assert math.exp(upper) == pytest.approx((1 - beta) / alpha, rel=RTOL)
    assert math.exp(lower) == pytest.approx(beta / (1 - alpha), rel=RTOL)
    assert LifecycleConfig(false_confirmation=alpha, false_deletion=beta).score_thresholds == (lower, upper)


def test_default_thresholds_and_what_they_mean_for_misses():
    lower, upper = LifecycleConfig().score_thresholds
    assert upper == pytest.approx(math.log((1 - 1e-3) / 1e-6), rel=RTOL)
    miss = math.log(1 - 0.9 * (1 - math.exp(-9.21 / 2)))  # ln(1 - P_D P_G) of the default trackers
    assert 3 * miss > lower > 4 * miss  # a confirmed track survives three misses, not four (M/N's max_misses)


def test_sprt_error_rates_obey_walds_bounds():
    """The test itself on a Gaussian shift (target: mean 1, clutter: mean 0, unit variance): the rate of
    accepting "target" under clutter is at most alpha / (1 - beta), and of rejecting it for a target
    at most beta / (1 - alpha) (Wald 1945)."""
    alpha, beta = 0.01, 0.05
    lower, upper = sprt_thresholds(alpha, beta)
    rng = np.random.default_rng(0)
    for mean, wrong, bound in ((0.0, "accept", alpha / (1 - beta)), (1.0, "reject", beta / (1 - alpha))):
        x = rng.normal(mean, 1.0, (20_000, 200))
        llr = np.cumsum(x - 0.5, axis=1)  # ln N(x; 1, 1) / N(x; 0, 1) per sample
        first_up = np.where((llr >= upper).any(1), (llr >= upper).argmax(1), 10**6)
        first_down = np.where((llr <= lower).any(1), (llr <= lower).argmax(1), 10**6)
        rate = np.mean(first_up < first_down) if wrong == "accept" else np.mean(first_down < first_up)
        assert rate <= bound


def test_start_score_and_advance_by_hand():
    cfg = LifecycleConfig()
    area = cfg.window_area(2.0, 30.0)
    assert area == pytest.approx(math.pi * (490.0**2 - 50.0**2), rel=RTOL)
    np.testing.assert_allclose(start_score(0.9, area, np.array([1e-6])), [math.log(0.9 / (area * 1e-6))], rtol=RTOL)
    lower, upper = cfg.score_thresholds
    P, C = TrackStatus.PRELIMINARY, TrackStatus.CONFIRMED
    early = math.log(0.1 / (1 - 1e-6))  # preliminary tracks: beta_p = 0.1
    status = np.array([P, P, P, C, C, C], np.int8)
    score = np.array([upper, early, early + 0.01, 20.0, 29.0 + lower, 31.0 + lower])
    max_score = np.array([upper, 1.0, 1.0, 20.0, 30.0, 30.0])
    np.testing.assert_array_equal(advance_score(status, score, max_score, cfg),
                                  [C, TrackStatus.DELETED, P, C, TrackStatus.DELETED, C])
    np.testing.assert_array_equal(advance_score(status, score, max_score, cfg, np.zeros(6, bool)), status)


@pytest.mark.parametrize("bad, fragment", [
    ({"false_confirmation": 0.0}, "greater than 0"), ({"false_confirmation": 1.0}, "less than 1"),
    ({"false_deletion": -0.1}, "greater than 0"), ({"false_deletion": 1.5}, "less than 1"),
    ({"false_confirmation": 0.5, "false_deletion": 0.6}, "must be below 1"),
    ({"preliminary_false_deletion": 0.0}, "greater than 0"),
    ({"false_confirmation": 0.5, "preliminary_false_deletion": 0.5}, "preliminary_false_deletion = 1"),
    ({"confirmation": "sprt"}, "'mn', 'score' or 'existence'"),
])
def test_bad_score_settings_are_refused(bad, fragment):
    from pydantic import ValidationError
    with pytest.raises(ValidationError, match=fragment):
        LifecycleConfig(**bad)


def _target_contacts_used(ds, outputs, after_scan: int) -> set[tuple[int, int]]:
    """(scan, target id) of every target contact that a confirmed track used after ``after_scan``."""
    bounds, target = ds.scan_bounds(), ds.detections.target_id
    return {(o.scan, int(target[bounds[o.scan - 1] + c]))
            for o in outputs if o.scan > after_scan
            for c in o.contact[(o.status == TrackStatus.CONFIRMED) & (o.contact != NO_CONTACT)].tolist()}


@pytest.mark.parametrize("kind", KINDS)
def test_score_and_mn_rules_give_the_same_tracks_without_clutter(kind, model_file):
    """Without clutter both rules confirm the same tracks (one per target, nothing else) and keep them, and once
    both have confirmed (the score confirms a scan or two sooner) their tracks use the same contacts."""
    sc = PRESETS["S6"].model_copy(update={"clutter": Clutter(law="none")})
    ds = generate(sc, 0)
    got = {}
    for rule in ("mn", "score"):
        tracker = make_tracker(kind, ds.scenario.sensors, _params(kind, model_file,
                                                                 {"lifecycle": {"confirmation": rule}}))
        outputs = [tracker.step(s) for s in ds.scans()]
        assert tracker.confirmation_rule == rule and tracker.track_management()["confirmation"] == rule
        m = run_metrics(ds, outputs)
        got[rule] = (m.confirmed_tracks - m.track_breaks, m.false_tracks, m.lost_targets,
                     _target_contacts_used(ds, outputs, 10))
    assert got["mn"][:3] == got["score"][:3] and got["mn"][1] == 0
    if kind != "nn":  # the small test model breaks a track on this scene, under either rule (and its
        # broken tracks end a scan apart under the two deletion rules)
        assert got["mn"][:3] == (len(sc.targets), 0, 0)
        assert got["mn"][3] == got["score"][3]


def _clutter_only(count: int) -> Scenario:
    """100 scans of ``count`` clutter points per scan in the presets' 34 km square and no detectable target
    (one target of PD 0: a scenario needs one)."""
    ghost = Target(name="ghost", x_m=0.0, y_m=15_000.0, heading_deg=90.0, speed_m_s=100.0, pd=0.0,
                   segments=[Segment(duration_s=200.0)])
    return Scenario(name=f"clutter-{count}", duration_s=200.0, targets=[ghost], seed=7,
                    clutter=Clutter(count=count, side_m=34_000.0, centre_m=(0.0, 15_000.0)))


def _confirmed_in_clutter(kind, count, model_file, params=SCORE) -> tuple[int, float]:
    ds = generate(_clutter_only(count), 7)
    tracker = make_tracker(kind, ds.scenario.sensors, _params(kind, model_file, params))
    confirmed, start = set(), time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for scan in ds.scans():
            out = tracker.step(scan)
            confirmed.update(out.track_id[out.status == TrackStatus.CONFIRMED].tolist())
    return len(confirmed), (time.perf_counter() - start) / ds.n_scans


@pytest.mark.parametrize("kind", ["gnn", "jpda"])
def test_clutter_only_scene_confirms_nothing_at_1000(kind, model_file):
    assert _confirmed_in_clutter(kind, 1_000, model_file)[0] == 0


@pytest.mark.parametrize("kind", ["gnn", "jpda"])
def test_existence_rule_confirms_no_clutter_at_1000(kind, model_file):
    """IPDA / JIPDA with the new-target prior at birth: nothing of 100 scans of 1,000 clutter points confirms
    (before the prior, clutter tracks started at the two-point ratio alone)."""
    assert _confirmed_in_clutter(kind, 1_000, model_file, {"lifecycle": {"confirmation": "existence"}})[0] == 0


@pytest.mark.slow
def test_jipda_confirms_no_clutter_at_5000(model_file):
    """JIPDA's existence on the reported contact's ratio (its soft ratio over a vague track's ~100 gated
    contacts confirmed 15 clutter tracks here)."""
    assert _confirmed_in_clutter("jpda", 5_000, model_file, {"lifecycle": {"confirmation": "existence"}})[0] == 0


@pytest.mark.slow
@pytest.mark.parametrize("count", [1_000, 5_000])
@pytest.mark.parametrize("kind", KINDS)
def test_clutter_only_scene_confirms_nothing(kind, count, model_file):
    assert _confirmed_in_clutter(kind, count, model_file)[0] == 0


def test_the_rule_each_tracker_runs_is_named_for_the_study():
    from nnda.tracking.registry import confirmation_rule
    assert confirmation_rule("gnn") == "adaptive" and confirmation_rule("nn", {"model": "m.json"}) == "adaptive"
    assert confirmation_rule("jpda", {"lifecycle": {"confirmation": "mn"}}) == "mn"
    assert confirmation_rule("mht", {"lifecycle": {"confirmation": "score"}}) == "score"
    assert confirmation_rule("gmphd") is None and confirmation_rule("stonesoup-gnn") is None


def test_the_score_rules_cap_keeps_every_target():
    """A cap of 300 live tracks at 1,000 clutter per scan (S1): the preliminary tracks of lowest score go,
    thousands of them, and every target still gets its confirmed track, with no false one."""
    sc = PRESETS["S1"]
    ds = generate(sc.model_copy(update={"clutter": sc.clutter.model_copy(update={"count": 1_000})}), 0)
    tracker = make_tracker("gnn", ds.scenario.sensors, {"lifecycle": {"confirmation": "score", "max_tracks": 300}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outputs = []
        for scan in ds.scans():
            outputs.append(tracker.step(scan))
            assert tracker.tracks is None or len(tracker.tracks) <= 300
    m = run_metrics(ds, outputs)
    assert m.false_tracks == 0 and m.confirmed_tracks - m.track_breaks == len(sc.targets)
    assert tracker.deletions["capped"] > 1_000


# ----------------------------------------------------------------------------- false tracks at a rate

@pytest.mark.parametrize("rate, beta, trials", [(0.005, 1e-3, 1), (0.005, 1e-3, 650), (0.1, 0.2, 37)])
def test_rate_threshold_is_walds_at_the_rate_over_the_trials(rate, beta, trials):
    upper = rate_threshold(rate, beta, trials)
    assert math.exp(upper) == pytest.approx((1 - beta) * trials / rate, rel=RTOL)
    assert upper == pytest.approx(sprt_thresholds(rate / trials, beta)[1], rel=RTOL)


def test_each_track_confirms_at_its_own_threshold():
    cfg = LifecycleConfig(confirmation="score", false_tracks_per_scan=0.005)
    P, C = TrackStatus.PRELIMINARY, TrackStatus.CONFIRMED
    status = np.full(3, P, np.int8)
    score = np.array([8.0, 8.0, 20.0])
    confirm_at = np.array([7.9, 8.1, 13.0])
    np.testing.assert_array_equal(advance_score(status, score, score, cfg, confirm_at=confirm_at), [C, P, C])


def _polar(x, y):
    return np.column_stack([np.hypot(x, y), np.arctan2(x, y)])


@pytest.mark.parametrize("kind", ["gnn", "jpda", "mht"])
def test_tracks_born_from_a_scans_initiators_take_the_rate_threshold(kind):
    """Three initiators 5 km apart, each met 300 m on by one contact of the next scan: three tracks, each to
    confirm at ln((1 - beta) 3 / r); without the rate, at Wald's threshold of false_confirmation."""
    from nnda.data.dataset import Scan
    from nnda.data.scenario import Sensor
    x0 = np.array([10_000.0, 15_000.0, 20_000.0])
    y0 = np.full(3, 10_000.0)
    scans = [Scan(1, 0.0, _polar(x0, y0)), Scan(2, 2.0, _polar(x0 + 300.0, y0))]
    for extra, want in (({"false_tracks_per_scan": 0.005}, rate_threshold(0.005, 1e-3, 3)),
                        ({}, LifecycleConfig().score_thresholds[1])):
        tracker = make_tracker(kind, Sensor(), {"lifecycle": {"confirmation": "score", **extra}})
        for scan in scans:
            tracker.step(scan)
        tracks = tracker.tracks if kind != "mht" else tracker.leaves.tracks
        np.testing.assert_allclose(tracks.confirm_at, np.full(3, want), rtol=RTOL)


def test_bad_rates_are_refused():
    from pydantic import ValidationError
    for bad, fragment in (({"false_tracks_per_scan": 0.0}, "greater than 0"),
                          ({"false_tracks_per_scan": 0.95}, "false_tracks_per_scan \\+ preliminary_false_deletion")):
        with pytest.raises(ValidationError, match=fragment):
            LifecycleConfig(**bad)


RATE = {"lifecycle": {"confirmation": "score", "false_tracks_per_scan": 0.005}}


def test_clutter_only_scene_confirms_nothing_at_1000_with_the_rate(model_file):
    assert _confirmed_in_clutter("gnn", 1_000, model_file, RATE)[0] == 0


@pytest.mark.slow
@pytest.mark.parametrize("count", [1_000, 5_000])
@pytest.mark.parametrize("kind", ["gnn", "jpda", "mht"])
def test_clutter_only_scene_confirms_nothing_with_the_rate(kind, count, model_file):
    assert _confirmed_in_clutter(kind, count, model_file, RATE)[0] == 0


def test_score_gain_by_hand():
    """One scan of the score rule's increments: ln(P_D l / lambda) for a chosen contact (l the IMM mixture
    likelihood, lambda the contacts counted in the 6 km square around it over its area, times the range,
    the polar area Jacobian) and ln(1 - P_D P_G) for a miss."""
    from scipy.special import logsumexp
    from scipy.stats import multivariate_normal

    from nnda.data.scenario import Sensor
    from nnda.filters.imm import IMM
    from nnda.tracking.marginals import log_miss_weight
    from nnda.tracking.tracker import ScanContacts
    from nnda.tracking.tracks import Association
    # contacts well inside the 5-30 km ring (every square wholly covered): a tight cluster of three, a pair
    # 2 km apart, and one alone; no contact within an eighth of the radius of another's square edge
    xy = np.array([[0.0, 12_000.0], [400.0, 12_300.0], [-300.0, 11_800.0], [9_000.0, 9_000.0],
                   [11_000.0, 9_000.0], [-10_000.0, -12_000.0]])
    counts = np.array([3, 3, 3, 2, 2, 1])
    z = _polar(*xy.T)
    tracker = make_tracker("gnn", Sensor(), SCORE)
    imm = IMM.for_sensor(Sensor())
    start = xy[[0, 3, 5, 4]] + [[-300.0, 0.0], [0.0, 250.0], [200.0, 200.0], [0.0, -300.0]]
    pred = imm.predict(imm.initialise(_polar(*(start - [0.0, 300.0]).T), _polar(*start.T), 0.0, 2.0), 2.0)
    contact = np.array([0, NO_CONTACT, 5, 4])
    scan = ScanContacts(3, 4.0, 0, imm, z, xy)
    gain = tracker._score_gain(pred, scan, Association(contact, pred.state))
    pd, mp = tracker.score_pd(0), pred.measurement
    for k, c in enumerate(contact):
        if c == NO_CONTACT:
            assert gain[k] == pytest.approx(log_miss_weight(pd, 9.21), rel=RTOL)
            continue
        nu = z[c] - mp.z[k]  # (r, 2)
        nu[:, 1] = (nu[:, 1] + math.pi) % (2 * math.pi) - math.pi  # predicted azimuths lie in [0, 2 pi)
        log_lik = logsumexp([multivariate_normal(np.zeros(2), mp.S[k, j]).logpdf(nu[j]) for j in range(2)],
                           b=pred.state.mu[k])
        density = counts[c] / 6_000.0**2 * z[c, 0]
        assert gain[k] == pytest.approx(math.log(pd) + log_lik - math.log(density), rel=RTOL)
