"""Local clutter density against direct counting."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import RegularGridInterpolator

from nnda.data.scenario import Sensor
from nnda.tracking.clutter_density import (
    _covered_cells,
    _covered_table,
    _density,
    covered_fraction,
    local_density,
    unexplained_density,
)
from tolerances import RTOL


def whole_table(contacts, at, radius, table, corner, strips=-1):
    """`_density` over a covered-part table computed whole (or none): the densities, every cell it read there."""
    out, missing = _density(contacts, at, radius, table, corner, strips)
    assert missing.shape == (0, 2)
    return out


def direct_count(contacts: np.ndarray, at: np.ndarray, radius: float) -> np.ndarray:
    """The contacts in each point's square, counted one by one (Q,): a contact counts when its cell of the
    radius/4 grid from the points' lower corner less radius and a cell lies in the square's cells [a, b),
    its edges rounded to the nearest grid line (the contract of `local_density`)."""
    cell = radius / 4
    lo = np.minimum(contacts.min(axis=0), at.min(axis=0)) - radius - cell
    index = np.floor_divide(contacts - lo, cell)  # (N, 2)
    a, b = np.rint((at - radius - lo) / cell), np.rint((at + radius - lo) / cell)  # (Q, 2)
    inside = (index[None] >= a[:, None]) & (index[None] < b[:, None])  # (Q, N, 2)
    return inside.all(axis=2).sum(axis=1)


def direct_sum(points: np.ndarray, weights: np.ndarray, contacts: np.ndarray, at: np.ndarray, radius: float
               ) -> np.ndarray:
    """The weights (K,) of the points (K, 2) in each point's square (Q,), summed one by one on the grid of
    `direct_count` (that of the contacts and the query points)."""
    cell = radius / 4
    lo = np.minimum(contacts.min(axis=0), at.min(axis=0)) - radius - cell
    index = np.floor_divide(points - lo, cell)
    a, b = np.rint((at - radius - lo) / cell), np.rint((at + radius - lo) / cell)
    inside = ((index[None] >= a[:, None]) & (index[None] < b[:, None])).all(axis=2)  # (Q, K)
    return inside @ weights


def covered_oracle(sensor: Sensor, at: np.ndarray, radius: float) -> np.ndarray:
    """The covered part at each point: bilinear interpolation of `_covered_table` between its cells'
    centres, a point beyond the outer centres taking the nearest edge's value."""
    table, lo = _covered_table(sensor, radius)
    centres = [lo[d] + (np.arange(len(table)) + 0.5) * (radius / 4) for d in range(2)]
    inside = np.clip(at, [c[0] for c in centres], [c[-1] for c in centres])
    return RegularGridInterpolator(centres, table)(inside)


points = st.integers(1, 60).flatmap(lambda n: st.lists(
    st.tuples(st.floats(-35_000, 35_000), st.floats(-35_000, 35_000)), min_size=n, max_size=n))


@settings(max_examples=200, deadline=None)
@given(contacts=points, at=points, radius=st.floats(50.0, 8_000.0), grid_points=st.booleans())
def test_counts_every_contact_in_the_cell_rounded_square(contacts, at, radius, grid_points):
    """The count is the direct one: max(n, 1) over the square's area (points on grid lines and
    exactly on the squares' edges included, when ``grid_points``: coordinates rounded to radius/4)."""
    contacts, at = np.array(contacts), np.array(at)
    if grid_points:
        contacts, at = (np.round(p / (radius / 4)) * (radius / 4) for p in (contacts, at))
    got = local_density(contacts, at, radius)
    # to rounding of the area's square (1 ulp seen), so a count off by one is still caught
    np.testing.assert_allclose(got, np.maximum(direct_count(contacts, at, radius), 1) / (2 * radius) ** 2, rtol=RTOL)


@settings(max_examples=100, deadline=None)
@given(contacts=points, at=points, radius=st.sampled_from([1_000.0, 3_000.0]),
       sector=st.sampled_from([(360.0, 0.0), (90.0, 45.0), (120.0, -100.0)]))
def test_the_area_is_the_interpolated_covered_part(contacts, at, radius, sector):
    sensor = Sensor(fov_deg=sector[0], boresight_deg=sector[1])
    contacts, at = np.array(contacts), np.array(at)
    got = local_density(contacts, at, radius, sensor)
    n = np.maximum(direct_count(contacts, at, radius), 1)
    np.testing.assert_allclose(got, n / ((2 * radius) ** 2 * covered_oracle(sensor, at, radius)), rtol=RTOL)


def test_the_squares_edges_are_exact_to_an_eighth_of_the_radius():
    rng = np.random.default_rng(0)
    contacts = rng.uniform(-20_000, 20_000, (3_000, 2))
    at = rng.uniform(-15_000, 15_000, (200, 2))
    r = 3_000.0
    got = local_density(contacts, at, r) * (2 * r) ** 2
    inner = (np.abs(contacts[None] - at[:, None]) < r - r / 8 - 1e-6).all(axis=2).sum(axis=1)
    outer = (np.abs(contacts[None] - at[:, None]) <= r + r / 8 + 1e-6).all(axis=2).sum(axis=1)
    assert np.all(got >= np.maximum(inner, 1) * (1 - RTOL)) and np.all(got <= np.maximum(outer, 1) * (1 + RTOL))
    # uniform density: the estimate is close to the truth on average
    truth = 3_000 / 40_000.0**2
    assert abs(np.mean(got / (2 * r) ** 2) / truth - 1) < 0.05


def test_never_zero():
    d = local_density(np.array([[0.0, 0.0]]), np.array([[50_000.0, 0.0], [0.0, 0.0]]), 1_000.0)
    assert d[0] == d[1] == 1 / 2_000.0**2
    assert local_density(np.empty((0, 2)), np.zeros((3, 2)), 1_000.0).tolist() == [1 / 2_000.0**2] * 3
    assert local_density(np.zeros((3, 2)), np.empty((0, 2)), 1_000.0).shape == (0,)


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
    their mean (bilinear interpolation); a sector's edges count as the ring's do. Read through the density
    of a point without contacts: one contact over the covered part of the square."""
    r = 3_000.0
    none = np.empty((0, 2))
    for sensor in (Sensor(), Sensor(fov_deg=90.0, boresight_deg=45.0)):
        table, lo = _covered_table(sensor, r)
        cell = r / 4
        rng = np.random.default_rng(5)
        idx = rng.integers(0, len(table), (500, 2))
        centres = lo + (idx + 0.5) * cell
        np.testing.assert_allclose(1 / ((2 * r) ** 2 * local_density(none, centres, r, sensor)),
                                   covered_fraction(sensor, centres, r), rtol=RTOL)
        idx = np.minimum(idx, len(table) - 2)
        np.testing.assert_allclose(1 / ((2 * r) ** 2 * local_density(none, lo + (idx + [1.0, 0.5]) * cell, r, sensor)),
                                   0.5 * (table[idx[:, 0], idx[:, 1]] + table[idx[:, 0] + 1, idx[:, 1]]), rtol=RTOL)
    edge = np.array([[0.0, 29_500.0], [29_500.0, 0.0]])  # beyond the 90-degree sector's edge at 0 degrees
    assert (covered_fraction(Sensor(fov_deg=90.0, boresight_deg=45.0), edge, 3_000.0) < 0.6).all()


def test_the_covered_part_is_shared_by_sensors_of_one_coverage():
    """Sensors that differ in noise, clutter, detection or timing share one table (it costs ~0.1 s to
    build); a sensor with another range, sector or position gets its own, equal to its covered part."""
    r = 3_000.0
    base = _covered_table(Sensor(), r)
    other = Sensor(name="other", sigma_range_m=50.0, pd=0.8, scan_period_s=4.0, clutter={"count": 1_000})
    assert _covered_table(other, r) is base
    assert _covered_cells(other, r) is _covered_cells(Sensor(), r)  # and the lazily filled one
    for sensor in (Sensor(max_range_m=20_000.0), Sensor(fov_deg=90.0), Sensor(x_m=1_000.0)):
        table, lo = _covered_table(sensor, r)
        assert table.shape != base[0].shape or not np.array_equal(table, base[0]) or not np.array_equal(lo, base[1])
        centres = lo + (np.array([[3, 7], [40, 20], [10, 50]]) + 0.5) * (r / 4)
        np.testing.assert_allclose(table[[3, 40, 10], [7, 20, 50]], covered_fraction(sensor, centres, r), rtol=RTOL)


def test_the_covered_part_is_filled_lazily_with_the_whole_tables_values():
    """A first scan computes only the cells its points read, not the coverage's (a 1,000 km radar's whole
    table would hold 7 million cells); filled over many scans, in any order, each cell holds the whole
    table's value to the bit, and the densities are the whole table's, bit for bit (a 90-degree sector
    offset from the origin, points inside and outside its coverage)."""
    r = 3_000.0
    far = Sensor(min_range_m=500.0, max_range_m=1_000_000.0)
    xy = np.array([[0.0, 999_000.0], [10_000.0, 20_000.0], [-400_000.0, 0.0]])
    local_density(xy, xy, r, far)
    table = _covered_cells(far, r)[0]
    assert table.size > 7_000_000 and np.count_nonzero(table) <= 4 * len(xy)
    sensor = Sensor(fov_deg=90.0, boresight_deg=30.0, x_m=1_234.5, y_m=-700.0, max_range_m=20_000.0)
    whole, lo = _covered_table(sensor, r)
    table = whole.astype(np.float32)  # the type of the lazy table (its values k / 256, exact in float32)
    rng = np.random.default_rng(3)
    none = np.empty((0, 2))
    for _ in range(20):
        at = rng.uniform(-25_000.0, 25_000.0, (100, 2))
        contacts = rng.uniform(-25_000.0, 25_000.0, (50, 2))
        assert np.array_equal(local_density(contacts, at, r, sensor), whole_table(contacts, at, r, table, lo))
        assert np.array_equal(local_density(none, at, r, sensor), whole_table(none, at, r, table, lo))
    cells, corner, _ = _covered_cells(sensor, r)
    filled = cells != 0
    assert np.array_equal(corner, lo) and 0.3 < filled.mean() < 1.0
    assert np.array_equal(cells[filled].astype(float), whole[filled])


@settings(max_examples=200, deadline=None)
@given(contacts=points, at=points, radius=st.floats(1_000.0, 8_000.0), grid_points=st.booleans(),
       scale=st.sampled_from([1.0, 10.0]))
def test_a_wide_scan_is_counted_by_strips_to_the_same_bits(contacts, at, radius, grid_points, scale):
    """Counted by strips (a scan whose grid is far larger than its points: a wide coverage) or over the grid's
    summed-area table, the same densities to the bit, with and without a covered-part table; the strips
    are chosen by default for the scaled points (350 km: a grid of up to 870,000 cells for 120 points). (The
    radius is at least 1 km here: a 50 m square's grid over 70 km would hold 31 million cells.)"""
    contacts, at = np.array(contacts) * scale, np.array(at) * scale
    radius = radius if scale == 1.0 else max(radius, 3_000.0)
    if grid_points:
        contacts, at = (np.round(p / (radius / 4)) * (radius / 4) for p in (contacts, at))
    table, lo = _covered_table(Sensor(max_range_m=35_000.0), 3_000.0)
    for t, c in ((table.astype(np.float32), lo), (np.empty((0, 0), np.float32), np.zeros(2))):
        grid = whole_table(contacts, at, radius, t, c, 0)
        assert np.array_equal(whole_table(contacts, at, radius, t, c, 1), grid)
        assert np.array_equal(whole_table(contacts, at, radius, t, c, -1), grid)  # -1: chosen by the grid's size



@settings(max_examples=150, deadline=None)
@given(contacts=points, at=points, tracks=points, radius=st.sampled_from([1_000.0, 3_000.0]),
       scale=st.sampled_from([1.0, 10.0]), seed=st.integers(0, 2**16))
def test_the_unexplained_count_leaves_out_the_tracks_expected_detections(contacts, at, tracks, radius, scale, seed):
    """The contacts in the square less the query's own and the expected detections of the tracks there, at
    least 0, over the area; at least the scan's contacts less every track's expected detections (at least
    one) over the scan's area. Counted on the grid or, for the scaled points (a 350 km extent), by strips."""
    contacts, at, tracks = (np.array(p) * scale for p in (contacts, at, tracks))
    rng = np.random.default_rng(seed)
    expected, own = rng.uniform(0.0, 1.0, len(tracks)), rng.integers(0, 2, len(at)).astype(float)
    area = 1e9 * scale**2
    got = unexplained_density(contacts, at, radius, area, None, tracks, expected, own)
    count = direct_count(contacts, at, radius) - own - direct_sum(tracks, expected, contacts, at, radius)
    want = np.maximum(np.maximum(count, 0.0) / (2 * radius) ** 2, max(len(contacts) - expected.sum(), 1.0) / area)
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=1e-12 / (2 * radius) ** 2)


def test_dense_targets_own_contacts_are_not_clutter():
    """Sparse uniform clutter over a 250 km coverage and 1,000 tracked targets in a 60 km square: at the
    targets' contacts the local count is mostly each contact itself and its neighbours (tens of times the
    clutter's density); without the contact itself and the tracks' expected detections, within half of the
    clutter's."""
    sensor = Sensor(max_range_m=250_000.0, min_range_m=500.0)
    rng = np.random.default_rng(7)
    r = np.sqrt(rng.uniform(sensor.min_range_m**2, sensor.max_range_m**2, 2_000))
    az = rng.uniform(-np.pi, np.pi, r.size)
    clutter = np.column_stack([r * np.cos(az), r * np.sin(az)])
    truth = len(clutter) / (np.pi * (sensor.max_range_m**2 - sensor.min_range_m**2))
    targets = rng.uniform(-30_000.0, 30_000.0, (1_000, 2)) + [100_000.0, 0.0]
    detected = rng.uniform(size=len(targets)) < 0.9
    contacts = np.concatenate([targets[detected] + rng.normal(0.0, 100.0, (detected.sum(), 2)), clutter])
    at = contacts[: detected.sum()]
    old = local_density(contacts, at, 3_000.0, sensor)
    new = unexplained_density(contacts, at, 3_000.0, np.pi * sensor.max_range_m**2, sensor, targets,
                              np.full(len(targets), 0.9), 1.0)
    assert np.mean(old) > 10 * truth
    assert abs(np.mean(new) / truth - 1) < 0.5  # 1.4: a square's count, clamped at 0 where it falls below


def test_no_contacts_and_no_queries():
    assert unexplained_density(np.empty((0, 2)), np.zeros((2, 2)), 1_000.0, 1e8).tolist() == [1e-8, 1e-8]
    assert unexplained_density(np.zeros((3, 2)), np.empty((0, 2)), 1_000.0, 1e8).shape == (0,)
