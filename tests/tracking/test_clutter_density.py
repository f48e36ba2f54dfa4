"""Local clutter density against direct counting."""

from __future__ import annotations

import numpy as np

from nnda.data.scenario import Sensor
from nnda.tracking.clutter_density import covered_fraction, local_density
from tolerances import RTOL


def test_matches_direct_count_up_to_the_grid_edge():
    rng = np.random.default_rng(0)
    contacts = rng.uniform(-20_000, 20_000, (3_000, 2))
    at = rng.uniform(-15_000, 15_000, (200, 2))
    r = 3_000.0
    got = local_density(contacts, at, r) * (2 * r) ** 2
    inner = (np.abs(contacts[None] - at[:, None]) <= r - r / 4).all(axis=2).sum(axis=1)
    outer = (np.abs(contacts[None] - at[:, None]) <= r + r / 4).all(axis=2).sum(axis=1)
    assert np.all(got >= np.maximum(inner, 1)) and np.all(got <= np.maximum(outer, 1))
    # uniform density: the estimate is close to the truth on average
    truth = 3_000 / 40_000.0**2
    assert abs(np.mean(got / (2 * r) ** 2) / truth - 1) < 0.05


def test_never_zero():
    d = local_density(np.array([[0.0, 0.0]]), np.array([[50_000.0, 0.0], [0.0, 0.0]]), 1_000.0)
    assert d[0] == d[1] == 1 / 2_000.0**2
    assert local_density(np.empty((0, 2)), np.zeros((3, 2)), 1_000.0).tolist() == [1 / 2_000.0**2] * 3


def test_the_area_is_the_squares_part_inside_the_coverage():
    """Uniform contacts over a radar's ring: at the maximum range about half the square sees clutter, and the
    density there, counted over that part only, matches the ring's (over the whole square: about half)."""
    sensor = Sensor()  # 5-30 km ring at the origin
    rng = np.random.default_rng(4)
    n = 200_000
    r = np.sqrt(rng.uniform(sensor.min_range_m**2, sensor.max_range_m**2, n))
    az = rng.uniform(-np.pi, np.pi, n)
    xy = np.column_stack([r * np.cos(az), r * np.sin(az)])
    true = n / (np.pi * (sensor.max_range_m**2 - sensor.min_range_m**2))
    at = np.array([[0.0, 30_000.0], [30_000.0, 0.0], [0.0, 17_000.0]])
    covered = local_density(xy, at, 1_000.0, sensor)
    np.testing.assert_allclose(covered, true, rtol=0.1)  # ~650 contacts per square: 4% noise
    assert (local_density(xy, at[:2], 1_000.0) < 0.6 * true).all()
    np.testing.assert_allclose(covered_fraction(sensor, at, 1_000.0), [0.5, 0.5, 1.0], atol=1 / 16)


def test_the_covered_part_is_tabulated_on_the_counting_cells():
    """The table holds the exact grid value at each cell's centre, and a point between two centres takes
    their mean (bilinear interpolation); a sector's edges count as the ring's do."""
    from nnda.tracking.clutter_density import _covered_lookup, _covered_table
    for sensor in (Sensor(), Sensor(fov_deg=90.0, boresight_deg=45.0)):
        table, lo, cell = _covered_table(sensor, 3_000.0)
        rng = np.random.default_rng(5)
        idx = rng.integers(0, len(table), (500, 2))
        centres = lo + (idx + 0.5) * cell
        np.testing.assert_array_equal(_covered_lookup(sensor, centres, 3_000.0), covered_fraction(sensor, centres,
                                                                                                   3_000.0))
        idx = np.minimum(idx, len(table) - 2)
        np.testing.assert_allclose(_covered_lookup(sensor, lo + (idx + [1.0, 0.5]) * cell, 3_000.0),
                                   0.5 * (table[idx[:, 0], idx[:, 1]] + table[idx[:, 0] + 1, idx[:, 1]]), rtol=RTOL)
    edge = np.array([[0.0, 29_500.0], [29_500.0, 0.0]])  # beyond the 90-degree sector's edge at 0 degrees
    assert (covered_fraction(Sensor(fov_deg=90.0, boresight_deg=45.0), edge, 3_000.0) < 0.6).all()
