"""The harbour of Lima (2022): occlusion geometry against a brute-force rule, and the preset's scene."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nnda.data.generator import generate
from nnda.data.occlusion import hidden
from nnda.data.presets import HARBOUR_SHIPS, PRESETS
from nnda.data.scenario import Scenario
from nnda.data.sensor import in_coverage
from nnda.errors import ConfigError, validated

RADAR = (0.0, 0.0)


def _one_scan(*ships: tuple[float, float, float]) -> np.ndarray:
    """Hidden flags of ships (x m, y m, length m) in one scan seen from the origin."""
    x, y, length = (np.array(c, dtype=float) for c in zip(*ships))
    return hidden(RADAR, np.ones(len(ships), np.int64), x, y, length)


def test_a_ship_behind_a_longer_one_is_hidden():
    # a 200 m hull at 2 km spans +/- atan(100 / 2000) = 2.86 degrees; the small ship 4 km out, 1 degree off
    off = 4_000.0 * math.sin(math.radians(1.0))
    assert _one_scan((0.0, 2_000.0, 200.0), (off, 4_000.0, 20.0)).tolist() == [False, True]


def test_beside_in_front_and_shorter_ships_are_seen():
    off = 4_000.0 * math.sin(math.radians(4.0))  # outside the 2.86-degree shadow
    assert _one_scan((0.0, 2_000.0, 200.0), (off, 4_000.0, 20.0)).tolist() == [False, False]
    assert _one_scan((0.0, 2_000.0, 20.0), (0.0, 4_000.0, 200.0)).tolist() == [False, False]  # shorter in front
    assert _one_scan((0.0, 4_000.0, 200.0), (0.0, 2_000.0, 20.0)).tolist() == [False, False]  # small one nearer
    assert _one_scan((0.0, 2_000.0, 0.0), (0.0, 4_000.0, 0.0)).tolist() == [False, False]  # points hide nothing


def test_only_ships_of_the_same_scan_hide_each_other():
    x, y, length = np.zeros(2), np.array([2_000.0, 4_000.0]), np.array([200.0, 20.0])
    assert not hidden(RADAR, np.array([1, 2]), x, y, length).any()
    assert hidden((0.0, 6_000.0), np.array([3, 3]), x, y[::-1], length).tolist() == [False, True]  # other origin


def _brute(origin, scan, x, y, length):
    out = []
    for i in range(len(scan)):
        ri, bi = math.hypot(x[i] - origin[0], y[i] - origin[1]), math.atan2(x[i] - origin[0], y[i] - origin[1])
        hid = False
        for j in range(len(scan)):
            if j == i or scan[j] != scan[i]:
                continue
            rj, bj = math.hypot(x[j] - origin[0], y[j] - origin[1]), math.atan2(x[j] - origin[0], y[j] - origin[1])
            d = abs((bi - bj + math.pi) % (2 * math.pi) - math.pi)
            hid |= rj < ri and length[j] > length[i] and d < math.atan(length[j] / 2 / rj)
        out.append(hid)
    return out


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 3), st.floats(-3e3, 3e3), st.floats(500.0, 6e3), st.sampled_from(
    [0.0, 20.0, 100.0, 400.0])), min_size=1, max_size=12))
def test_hidden_matches_the_pairwise_rule(rows):
    scan, x, y, length = (np.array(c) for c in zip(*rows))
    assert hidden(RADAR, scan, x, y, length).tolist() == _brute(RADAR, scan, x, y, length)


def test_the_harbour_scene():
    """Five ships inside both sectors at the start; radar 2 loses ship 3 behind ship 2 for about a quarter of
    the scans, radar 1 never; the dense variant has about 50 clutter points per sweep."""
    sc = PRESETS["harbour"]
    assert [s.name for s in sc.sensors] == ["radar1", "radar2"] and len(sc.targets) == len(HARBOUR_SHIPS) == 5
    ds = generate(sc, seed=0)
    t, sweep = ds.truth, ds.scan_sensor[ds.truth.scan - 1]
    first = t.scan <= 2
    for s in sc.sensors:
        assert in_coverage(s, t.x[first], t.y[first]).all()
    for radar in (0, 1):
        hid = hidden(sc.sensors[radar].position, t.scan[sweep == radar], t.x[sweep == radar], t.y[sweep == radar],
                     np.array([ship[-1] for ship in HARBOUR_SHIPS])[t.target_id[sweep == radar]])
        ids = t.target_id[sweep == radar][hid]
        assert set(ids.tolist()) == ({2} if radar == 1 else set())
        assert not t.detected[sweep == radar][hid].any()
    assert 40 <= hid.sum() <= 60
    dense = generate(PRESETS["harbour-dense"], seed=0)
    per_sweep = np.bincount(dense.detections.scan[dense.detections.is_clutter], minlength=dense.n_scans + 1)[1:]
    assert 45 < per_sweep.mean() < 55


def test_a_hull_length_must_be_positive():
    data = PRESETS["harbour"].model_dump()
    data["targets"][0]["length_m"] = 0.0
    with pytest.raises(ConfigError, match=r"targets\.0\.length_m"):
        validated(Scenario, data, "harbour", "scenario")


def test_a_radar_whose_sector_misses_every_ship_is_named():
    from nnda.data.generator import check_scenario

    sc = PRESETS["harbour"]
    away = sc.model_copy(update={"sensors": (sc.sensors[0].model_copy(update={"boresight_deg": 124.0}),
                                             sc.sensors[1])})
    assert check_scenario(sc) == []
    assert check_scenario(away) == ["scenario 'harbour': sensor 'radar1' sees no target at any of its sweeps (its "
                                    "coverage misses every target): its scans hold clutter only"]
