from __future__ import annotations

import numpy as np
import pytest

from nnda.errors import ModelError
from nnda.models.features import (
    candidate_pairs, neighbour_sectors, pair_features, passes_gate, sector,
)


def feats(p1, t1, p2, t2, c, tc):
    return pair_features(np.array([p1], float), [t1], np.array([p2], float), [t2], np.array([c], float), [tc])[0]


def test_straight_line_at_constant_speed_gives_zero_changes():
    # 100 m/s due north, one scan period between contacts
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
    np.testing.assert_array_equal(batch, rows)
    assert np.all(np.abs(batch[:, 1] * batch[:, 2]) <= 180.0)


def test_bad_input_is_refused():
    ok = dict(p1=np.zeros((1, 2)), t1=[0.0], p2=np.ones((1, 2)), t2=[2.0], c=np.full((1, 2), 3.0), tc=[4.0])
    with pytest.raises(ModelError, match="c has a non-finite value at row 0"):
        pair_features(**{**ok, "c": np.array([[np.nan, 0.0]])})
    with pytest.raises(ModelError, match="t1 < t2 < tc"):
        pair_features(**{**ok, "tc": [2.0]})
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
