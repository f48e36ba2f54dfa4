"""The clutter-adaptive confirmation rule, every contact tracker's default."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.tracking.clutter_density import local_density
from nnda.tracking.confirmation_bound import clairvoyant_delay_s
from nnda.tracking.lifecycle import (
    THESIS_LIFECYCLE,
    LifecycleConfig,
    adaptive_deletion,
    adaptive_threshold,
    advance_score,
    miss_run,
    sprt_thresholds,
)
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import TRACKERS, confirmation_rule, make_tracker
from nnda.tracking.tracker import CLUTTER_RADIUS_M, ContactTracker
from tolerances import RTOL

CONTACT_KINDS = [name for name, cls in TRACKERS.items() if issubclass(cls, ContactTracker)]


def test_the_threshold_is_walds_at_the_rate_over_the_clutter():
    """alpha = phi T / rho, phi in false tracks per hour per 1,000 km^2: Wald's upper threshold at that alpha,
    ln 10 higher where the clutter is ten times denser."""
    rate, beta, rho, period = 2.0, 1e-3, 8.7e-8, 2.0
    alpha = rate / (3600.0 * 1e9) * period / rho
    got = adaptive_threshold(rate, beta, np.array([rho, 10 * rho]), period)
    np.testing.assert_allclose(got[0], sprt_thresholds(alpha, beta)[1], rtol=RTOL)
    np.testing.assert_allclose(got[1] - got[0], math.log(10.0), rtol=RTOL)
    # a slower radar sweeps fewer trials an hour: each may confirm more easily
    assert adaptive_threshold(rate, beta, np.array([rho]), 10.0)[0] < got[0]


def test_every_contact_tracker_runs_it_by_default_and_the_thesis_rule_is_one_setting(model_file):
    assert LifecycleConfig().confirmation == "adaptive"
    assert LifecycleConfig(**THESIS_LIFECYCLE).confirmation == "mn"
    for kind in CONTACT_KINDS:
        params = {"model": str(model_file)} if kind == "nn" else {}
        own = TRACKERS[kind].own_confirmation  # a tracker confirming by its own posterior says which
        assert make_tracker(kind, Sensor(), params).confirmation_rule == (own or "adaptive"), kind
        assert confirmation_rule(kind, params) == (own or "adaptive"), kind


def _polar(x, y):
    return np.column_stack([np.hypot(x, y), np.arctan2(x, y)])


@pytest.mark.parametrize("kind", ["gnn", "jpda", "mht"])
def test_each_track_confirms_at_the_threshold_of_the_clutter_where_it_was_born(kind):
    """Three initiators, each met 300 m on by a contact of the next scan, with 0, 4 and 12 more contacts
    within a few hundred metres of the third (outside every window): each track's thresholds (confirmation
    and deletion) are the adaptive ones of the local clutter density at its second contact."""
    x0 = np.array([10_000.0, 16_000.0, 22_000.0])
    y0 = np.full(3, 10_000.0)
    rng = np.random.default_rng(3)
    crowd = [(x0[1] + rng.uniform(2_000, 2_500, 4)), (x0[2] + rng.uniform(2_000, 2_500, 12))]
    extra_x = np.concatenate(crowd)
    extra_y = y0[0] + rng.uniform(-300, 300, extra_x.size)
    z2 = _polar(np.concatenate([x0 + 300.0, extra_x]), np.concatenate([y0, extra_y]))
    scans = [Scan(1, 0.0, _polar(x0, y0)), Scan(2, 2.0, z2)]
    sensor = Sensor()
    tracker = make_tracker(kind, sensor, {})
    for scan in scans:
        tracker.step(scan)
    tracks = tracker.tracks if kind != "mht" else tracker.leaves.tracks
    cfg = LifecycleConfig()
    xy = np.column_stack([z2[:, 0] * np.sin(z2[:, 1]), z2[:, 0] * np.cos(z2[:, 1])])
    density = local_density(xy, xy[:3], CLUTTER_RADIUS_M, sensor)
    want = adaptive_threshold(cfg.false_track_rate, cfg.false_deletion, density, sensor.scan_period_s)
    order = np.argsort(tracks.track_id)
    np.testing.assert_allclose(tracks.confirm_at[order], want, rtol=RTOL)
    assert want[0] < want[1] < want[2]  # the crowded places confirm later
    np.testing.assert_allclose(tracks.delete_at[order], adaptive_deletion(cfg, density), rtol=RTOL)


def _clutter_only(count: int) -> Scenario:
    """100 scans of ``count`` clutter points in a 34 km square (1,156 km^2) and no detectable target."""
    ghost = Target(name="ghost", x_m=0.0, y_m=15_000.0, heading_deg=90.0, speed_m_s=100.0, pd=0.0,
                   segments=[Segment(duration_s=200.0)])
    return Scenario(name=f"clutter-{count}", duration_s=200.0, targets=[ghost], seed=7,
                    clutter=Clutter(count=count, side_m=34_000.0, centre_m=(0.0, 15_000.0)))


def _false_confirmed(kind: str, count: int, rate: float) -> int:
    ds = generate(_clutter_only(count), 7)
    tracker = make_tracker(kind, ds.scenario.sensors, {"lifecycle": {"false_track_rate": rate}})
    confirmed = set()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for scan in ds.scans():
            out = tracker.step(scan)
            confirmed.update(out.track_id[out.status == TrackStatus.CONFIRMED].tolist())
    return len(confirmed)


@pytest.mark.parametrize("count", [100, 1_000])
def test_false_tracks_stay_within_the_rate_whatever_the_clutter(count):
    """On clutter alone, the false tracks a run are at most about what the rate allows over the clutter's
    area and the run's duration, at 100 and at 1,000 clutter points a scan: none at the default rate (0.13
    allowed), and some but within the allowance at a rate 200 times it (26 allowed)."""
    allowed = 1.156 * (200.0 / 3600.0)  # per unit of rate: 1,156 km^2 for 200 s
    assert _false_confirmed("gnn", count, 2.0) == 0
    many = _false_confirmed("gnn", count, 400.0)
    assert 0 < many <= 400.0 * allowed


def test_its_confirmation_delay_bound_lies_between_the_score_rules_at_the_two_densities():
    """The clairvoyant delay of the adaptive rule grows with the clutter faster than the fixed score rule's
    (its threshold rises by ln 10 a decade) and is shorter where clutter is sparse."""
    cfg = LifecycleConfig()
    args = (17_500.0, 30.0, 3e-3, 2.0)
    sparse, dense = (clairvoyant_delay_s("adaptive", cfg, rho, *args) for rho in (8.7e-8, 8.7e-7))
    fixed_sparse, fixed_dense = (clairvoyant_delay_s("score", cfg, rho, *args) for rho in (8.7e-8, 8.7e-7))
    assert sparse < fixed_sparse and dense - sparse > fixed_dense - fixed_sparse


def test_the_deletion_threshold_falls_with_the_clutter_down_to_a_hundredth_of_beta():
    """beta_k = beta min(1, rho / rho_dense), at least beta / 100: ln(beta_k / (1 - alpha))."""
    cfg = LifecycleConfig()  # rho_dense 1 per km^2, beta 1e-3, alpha 1e-6
    rho = np.array([2e-6, 1e-6, 1e-7, 1e-9])  # per m^2: 2, 1, 0.1 and 0.001 per km^2
    want = np.log(1e-3 * np.array([1.0, 1.0, 0.1, 0.01])) - math.log1p(-1e-6)
    np.testing.assert_allclose(adaptive_deletion(cfg, rho), want, rtol=RTOL)
    assert adaptive_deletion(cfg, rho)[0] == cfg.score_thresholds[0]  # dense clutter: the score rule's


def test_a_confirmed_track_survives_max_misses_in_a_row_and_not_one_more():
    """Under the adaptive rule a confirmed track whose score has not fallen far enough is still deleted at its
    (max_misses + 1)-th miss in a row; under the score rule only its score counts."""
    C, D = TrackStatus.CONFIRMED, TrackStatus.DELETED
    status = np.full(3, C, np.int8)
    score, best = np.full(3, 10.0), np.full(3, 14.0)  # fallen 4, short of either rule's threshold
    delete_at = np.full(3, -9.2)
    consecutive = np.array([2, 3, 4])
    for rule, want in (("adaptive", [C, C, D]), ("score", [C, C, C])):
        cfg = LifecycleConfig(confirmation=rule)
        got = advance_score(status, score, best, cfg, delete_at=delete_at, consecutive=consecutive)
        np.testing.assert_array_equal(got, want, err_msg=rule)
    assert miss_run(LifecycleConfig()) == LifecycleConfig().max_misses == 3
