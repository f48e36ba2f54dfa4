from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nnda.errors import ModelError
from nnda.models.features import (
    MAX_SPEED_M_S,
    MIN_SPEED_M_S,
    candidate_pairs,
    needed_speed,
    neighbour_sectors,
    pair_features,
    passes_gate,
    sector,
)
from tolerances import RTOL


def feats(p1, t1, p2, t2, c, tc):
    return pair_features(np.array([p1], float), [t1], np.array([p2], float), [t2], np.array([c], float), [tc])[0]


def test_straight_line_at_constant_speed_gives_zero_changes():
    # 100 m/s due north, one scan period between contacts
    # exact zeros: every length and time here is an integer
    assert feats((0, 10_000), 0, (0, 10_200), 2, (0, 10_400), 4) == pytest.approx([0.0, 0.0, 2.0], abs=1e-12)


def test_speed_change_and_gap():
    # previous 100 m/s; candidate 600 m away after a 4 s gap (one missed scan) -> 150 m/s
    dv, da, dt = feats((0, 10_000), 0, (0, 10_200), 2, (0, 10_800), 6)
    assert (dv, da, dt) == pytest.approx((50.0, 0.0, 4.0))


@pytest.mark.parametrize("turn_deg", [10.0, -10.0, 45.0])
def test_known_turn_gives_course_rate_in_deg_per_s_positive_to_the_right(turn_deg):
    # heading east (090), candidate on a course turned by turn_deg (clockwise positive)
    course = np.radians(90.0 + turn_deg)
    c = (1000 + 200 * np.sin(course), 5000 + 200 * np.cos(course))
    dv, da, dt = feats((800, 5000), 10, (1000, 5000), 12, c, 14)
    assert dv == pytest.approx(0.0, abs=1e-9)
    assert da == pytest.approx(turn_deg / 2.0)
    assert dt == 2.0


def test_course_change_wraps_through_south():
    # from course 170 deg to course 190 deg is a 20 deg right turn, not -340
    p1 = (0.0, 0.0)
    p2 = (100 * np.sin(np.radians(170)), 100 * np.cos(np.radians(170)))
    c = (p2[0] + 100 * np.sin(np.radians(190)), p2[1] + 100 * np.cos(np.radians(190)))
    assert feats(p1, 0, p2, 2, c, 4)[1] == pytest.approx(10.0)


def test_reversal_is_plus_180():
    assert feats((0, 0), 0, (0, 100), 2, (0, 0), 4)[1] == pytest.approx(90.0)  # +180 deg over 2 s


def test_batch_equals_rows():
    rng = np.random.default_rng(1)
    n = 50
    p1, p2, c = (rng.uniform(-2e4, 2e4, (n, 2)) for _ in range(3))
    t1 = rng.uniform(0, 10, n)
    t2 = t1 + rng.choice([2.0, 4.0], n)
    tc = t2 + rng.choice([2.0, 4.0, 6.0, 8.0], n)
    batch = pair_features(p1, t1, p2, t2, c, tc)
    rows = np.array([feats(p1[i], t1[i], p2[i], t2[i], c[i], tc[i]) for i in range(n)])
    # numpy may run another SIMD loop over one element than over 50: each feature (a difference of speeds
    # or courses) equal to rounding, 1e-9 of its largest value
    for j, scale in enumerate(np.abs(rows).max(axis=0)):
        np.testing.assert_allclose(batch[:, j], rows[:, j], rtol=1e-9, atol=1e-9 * scale)
    assert np.all(np.abs(batch[:, 1] * batch[:, 2]) <= 180.0)


def test_bad_input_is_refused():
    ok = dict(p1=np.zeros((1, 2)), t1=[0.0], p2=np.ones((1, 2)), t2=[2.0], c=np.full((1, 2), 3.0), tc=[4.0])
    with pytest.raises(ModelError, match=r"pair features: c: non-finite value nan at index \(0, "):
        pair_features(**{**ok, "c": np.array([[np.nan, 0.0]])})
    for tc in (2.0, 1.0):  # a zero gap (infinite features) and a negative one (finite features)
        with pytest.raises(ModelError, match="t1 < t2 < tc"):
            pair_features(**{**ok, "tc": [tc]})
    with pytest.raises(ModelError, match="t1 < t2 < tc"):
        pair_features(**{**ok, "t1": [3.0]})
    with pytest.raises(ModelError, match="shape"):
        pair_features(**{**ok, "p2": np.ones(2)})


def test_sectors_are_22_5_degree_wedges_from_north():
    deg = np.radians([0.0, 22.49, 22.5, 180.0, 359.99, 360.0, -1.0])
    assert sector(deg).tolist() == [0, 0, 1, 8, 15, 0, 15]


def test_neighbour_sectors_wrap():
    track = np.zeros(16, dtype=int)
    assert np.flatnonzero(neighbour_sectors(track, np.arange(16))).tolist() == [0, 1, 15]
    assert np.flatnonzero(neighbour_sectors(np.full(16, 15), np.arange(16))).tolist() == [0, 14, 15]


def test_speed_gate_bounds_are_inclusive():
    p2, s = np.array([0.0, 10_000.0]), sector(0.0)
    for dist, expected in [(59.9, False), (60.0, True), (800.0, True), (800.1, False)]:
        assert bool(passes_gate(p2, 0.0, s, p2 + [0.0, dist], 2.0, s)) is expected


def test_candidate_pairs_match_elementwise_gate():
    rng = np.random.default_rng(4)
    last = rng.uniform(-15_000, 15_000, (7, 2))
    contacts = np.concatenate([last + rng.normal(0, 300, last.shape), rng.uniform(-15_000, 15_000, (40, 2))])
    az_last = np.arctan2(last[:, 0], last[:, 1])
    az_c = np.arctan2(contacts[:, 0], contacts[:, 1])
    t_last = np.array([2.0, 4.0, 6.0, 6.0, 4.0, 2.0, 6.0])
    track, contact = candidate_pairs(last, t_last, az_last, contacts, az_c, 8.0)
    expected = [(i, j) for i in range(7) for j in range(len(contacts))
                if passes_gate(last[i], t_last[i], sector(az_last[i]), contacts[j], 8.0, sector(az_c[j]))]
    assert list(zip(track.tolist(), contact.tolist())) == expected
    assert len(expected) > 0


def _gating_problem(rng, M, N):
    """M tracks and N contacts over a 20 km square at t = 10 s; contact j < min(M, N // 4) lies due
    north of track j's last contact at 400 or 30 m/s from it: on the speed gate's bounds (included)."""
    last = rng.uniform(-10_000, 10_000, (M, 2)) + [0.0, 15_000.0]
    t_last = rng.choice([2.0, 4.0, 6.0, 8.0], M, p=[0.7, 0.1, 0.1, 0.1])
    n_edge = min(M, N // 4)
    speed = rng.choice([MIN_SPEED_M_S, MAX_SPEED_M_S], n_edge)
    edge = last[:n_edge] + np.column_stack([np.zeros(n_edge), speed * (10.0 - t_last[:n_edge])])
    contacts = np.concatenate([edge, rng.uniform(-10_000, 10_000, (N - n_edge, 2)) + [0.0, 15_000.0]])
    return (last, t_last, np.arctan2(last[:, 0], last[:, 1]),
            contacts, np.arctan2(contacts[:, 0], contacts[:, 1]), 10.0)


# ---- brute-force oracles: the gate and the features in plain Python floats, one pair at a time


def oracle_sector(azimuth):
    return int(math.floor((azimuth % (2 * math.pi)) / (2 * math.pi / 16))) % 16


def oracle_gate(p2, t2, az2, c, tc, azc):
    """Sector gate (the track's sector or a neighbour, wrapping) and speed gate 30..400 m/s, bounds in."""
    if (oracle_sector(azc) - oracle_sector(az2)) % 16 not in (0, 1, 15):
        return False
    v = math.hypot(c[0] - p2[0], c[1] - p2[1]) / (tc - t2)
    return 30.0 <= v <= 400.0


def oracle_pairs(last, t_last, az_last, contacts, az_c, time):
    return [(i, j) for i in range(len(last)) for j in range(len(contacts))
            if oracle_gate(last[i], t_last[i], az_last[i], contacts[j], time, az_c[j])]


def oracle_features(p1, t1, p2, t2, c, tc):
    lx, ly, sx, sy = p2[0] - p1[0], p2[1] - p1[1], c[0] - p2[0], c[1] - p2[1]
    dv = math.hypot(sx, sy) / (tc - t2) - math.hypot(lx, ly) / (t2 - t1)
    change = math.atan2(lx, ly) - math.atan2(sx, sy)  # course: bearing clockwise from north
    turn = -((change + math.pi) % (2 * math.pi) - math.pi)  # to (-pi, pi]
    return [dv, math.degrees(turn) / (tc - t2), tc - t2]


def numpy_pairs(last, t_last, az_last, contacts, az_c, time):
    """Every track-contact pair through the gate in numpy: the formulation the compiled search replaced."""
    sec = lambda a: np.floor(a % (2 * np.pi) / (2 * np.pi / 16)).astype(np.int64) % 16  # noqa: E731
    near = (sec(az_c)[None, :] - sec(az_last)[:, None] + 1) % 16 <= 2
    v = np.hypot(contacts[:, 0] - last[:, 0, None], contacts[:, 1] - last[:, 1, None]) / (time - t_last)[:, None]
    return np.nonzero(near & (v >= 30.0) & (v <= 400.0))


def _positions_near(draw, n, scale):
    return np.array([[draw(st.floats(-scale, scale)), draw(st.floats(-scale, scale))] for _ in range(n)]).reshape(n, 2)


@st.composite
def gating_problems(draw):
    """Tracks and contacts over a box of 1 m to 100 km (around the radar: every sector; or far out), some
    contacts exactly on a track's speed bounds or beside a sector edge, times since the last contact from
    a millisecond to 10 s."""
    M, N = draw(st.integers(0, 8)), draw(st.integers(0, 30))
    scale = draw(st.sampled_from([1.0, 2_000.0, 20_000.0, 100_000.0]))
    offset = draw(st.sampled_from([0.0, 30_000.0]))
    last = _positions_near(draw, M, scale) + [0.0, offset]
    contacts = _positions_near(draw, N, scale) + [0.0, offset]
    time = 10.0
    t_last = np.array([time - draw(st.sampled_from([2.0, 4.0, 8.0]) | st.floats(1e-3, 10.0)) for _ in range(M)])
    for j in range(min(M, N) if draw(st.booleans()) else 0):  # contact j on track j's bound, due north
        speed = draw(st.sampled_from([MIN_SPEED_M_S, MAX_SPEED_M_S]))
        contacts[j] = last[j] + [0.0, speed * (time - t_last[j])]
    az = lambda p: np.arctan2(p[:, 0], p[:, 1]) if len(p) else np.empty(0)  # noqa: E731
    az_last, az_c = az(last), az(contacts)
    if N and draw(st.booleans()):  # a contact on a sector edge: 22.5 deg x k, exactly, and just below
        az_c[0] = np.radians(22.5) * draw(st.integers(-16, 32)) - draw(st.sampled_from([0.0, 1e-12]))
    return last, t_last, az_last, contacts, az_c, time


@settings(max_examples=300, deadline=None)
@given(gating_problems())
def test_candidate_pairs_against_brute_force(problem):
    track, contact = candidate_pairs(*problem)
    assert track.dtype == contact.dtype == np.int64
    assert list(zip(track.tolist(), contact.tolist())) == oracle_pairs(*problem)  # same pairs, same order


@pytest.mark.parametrize("seed", range(3))
def test_candidate_pairs_of_big_scans_equal_every_pair_through_the_gate(seed):
    # hundreds of tracks, thousands of contacts (a grid of many cells), some on the speed bounds
    rng = np.random.default_rng(seed)
    problem = _gating_problem(rng, int(rng.integers(100, 400)), int(rng.integers(1_000, 4_000)))
    track, contact = candidate_pairs(*problem)
    expected = numpy_pairs(*problem)
    assert len(track) > 500
    np.testing.assert_array_equal(track, expected[0])
    np.testing.assert_array_equal(contact, expected[1])
    last, t_last, _, contacts, _, time = problem  # the bounds are met: pairs at exactly 400 and 30 m/s
    v = needed_speed(last[track], t_last[track], contacts[contact], time)
    assert (v == MAX_SPEED_M_S).any() and (v == MIN_SPEED_M_S).any()


def test_candidate_pairs_with_contacts_far_apart_or_all_in_one_place():
    # a 10,000 km spread (the grid's cells grow to keep their number near 2 per contact) and a zero spread
    rng = np.random.default_rng(5)
    last = rng.uniform(-1e3, 1e3, (20, 2))
    t_last = np.full(20, 8.0)
    for contacts in (np.concatenate([last + [0.0, 500.0], rng.uniform(-5e6, 5e6, (200, 2))]),
                     np.repeat(last[:1] + [300.0, 0.0], 50, axis=0)):
        problem = (last, t_last, np.arctan2(last[:, 0], last[:, 1]), contacts,
                   np.arctan2(contacts[:, 0], contacts[:, 1]), 10.0)
        track, contact = candidate_pairs(*problem)
        assert list(zip(track.tolist(), contact.tolist())) == oracle_pairs(*problem)
        assert len(track) > 0


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 20), st.data())
def test_pair_features_against_brute_force(n, data):
    rows = []
    for _ in range(n):
        p1, p2, c = (data.draw(st.tuples(st.floats(-5e4, 5e4), st.floats(-5e4, 5e4))) for _ in range(3))
        t1 = data.draw(st.floats(0.0, 100.0))
        t2 = t1 + data.draw(st.sampled_from([2.0, 4.0]) | st.floats(1e-3, 20.0))
        tc = t2 + data.draw(st.sampled_from([2.0, 4.0, 8.0]) | st.floats(1e-3, 20.0))
        rows.append((p1, t1, p2, t2, c, tc))
    p1, t1, p2, t2, c, tc = (np.array(a, float) for a in zip(*rows))
    got = pair_features(p1, t1, p2, t2, c, tc)
    expected = np.array([oracle_features(*r) for r in rows])
    # ΔV and Δα are differences of speeds and courses: equal to rounding, RTOL of their terms' size
    scale = np.column_stack([np.hypot(*(c - p2).T) / (tc - t2) + np.hypot(*(p2 - p1).T) / (t2 - t1),
                             360.0 / (tc - t2), tc - t2])
    np.testing.assert_array_less(np.abs(got - expected), RTOL * scale + 1e-300)


def test_gate_helpers_against_brute_force():
    rng = np.random.default_rng(8)
    az = np.concatenate([rng.uniform(-10, 20, 500), np.radians(22.5) * np.arange(-32, 33), [np.nextafter(0, -1)]])
    assert sector(az).tolist() == [oracle_sector(a) for a in az]
    s2, sc = rng.integers(0, 16, 300), rng.integers(0, 16, 300)
    assert neighbour_sectors(s2, sc).tolist() == [(b - a) % 16 in (0, 1, 15) for a, b in zip(s2, sc)]
    p2, c = rng.uniform(-3e3, 3e3, (300, 2)), rng.uniform(-3e3, 3e3, (300, 2))
    t2, tc = rng.uniform(0, 5, 300), rng.uniform(6, 20, 300)
    assert passes_gate(p2, t2, sector(az[:300]), c, tc, sector(az[200:500])).tolist() == [
        oracle_gate(p2[i], t2[i], az[i], c[i], tc[i], az[200 + i]) for i in range(300)]
    assert passes_gate(p2[:, None], t2[:, None], 0, c[None], tc[None], 0).shape == (300, 300)  # broadcasts
    np.testing.assert_array_equal(needed_speed(p2, t2, c, tc), [math.hypot(*(c[i] - p2[i])) / (tc[i] - t2[i])
                                                                for i in range(300)])


def test_candidate_pairs_bad_input_is_refused():
    last, t_last, az_last, contacts, az_c, time = _gating_problem(np.random.default_rng(3), 4, 8)
    with pytest.raises(ModelError, match=r"candidate pairs: contacts: non-finite value nan at index \(5, "):
        candidate_pairs(last, t_last, az_last, np.where(np.arange(8)[:, None] == 5, np.nan, contacts), az_c, time)
    with pytest.raises(ModelError, match=r"candidate pairs: last_time: non-finite value inf at index \(2,\)"):
        candidate_pairs(last, np.where(np.arange(4) == 2, np.inf, t_last), az_last, contacts, az_c, time)
    with pytest.raises(ModelError, match="last_time must come before time = 10.0 s; row 1 has 10.0 s"):
        candidate_pairs(last, np.where(np.arange(4) == 1, 10.0, t_last), az_last, contacts, az_c, time)
    with pytest.raises(ModelError, match="candidate pairs: time: non-finite value"):
        candidate_pairs(last, t_last, az_last, contacts, az_c, np.nan)
    with pytest.raises(ModelError, match=r"contact_azimuth must have shape \(8,\)"):
        candidate_pairs(last, t_last, az_last, contacts, az_c[:7], time)
    with pytest.raises(ModelError, match=r"last must have shape \(N, 2\)"):
        candidate_pairs(last[:, 0], t_last, az_last, contacts, az_c, time)
    empty = candidate_pairs(last[:0], t_last[:0], az_last[:0], contacts, az_c, time)
    assert [a.size for a in empty] == [0, 0]


def test_scalar_times_broadcast_and_misshapen_times_are_refused():
    rng = np.random.default_rng(2)
    p1, p2, c = (rng.uniform(-2e4, 2e4, (6, 2)) for _ in range(3))
    # exactly: the same arithmetic on the same values, only broadcast
    np.testing.assert_array_equal(pair_features(p1, 0.0, p2, 2.0, c, 4.0),
                                  pair_features(p1, np.zeros(6), p2, np.full(6, 2.0), c, np.full(6, 4.0)))
    with pytest.raises(ModelError, match=r"t2 must be a scalar or have shape \(6,\)"):
        pair_features(p1, 0.0, p2, np.full(5, 2.0), c, 4.0)
    with pytest.raises(ModelError, match=r"pair features: p1: non-finite value -inf at index \(3, 0\)"):  # caught even
        pair_features(np.where(np.arange(6)[:, None] == 3, -np.inf, p1), 0.0, p2, 2.0, c, 4.0)  # where -inf cancels
    with pytest.raises(ModelError, match=r"pair features: t1: non-finite value .* at index \(1,\)"):
        pair_features(p1, np.array([0.0, -np.inf, 0, 0, 0, 0]), p2, 2.0, c, 4.0)
