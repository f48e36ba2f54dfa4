"""Clutter density from a scan's own contacts, for the MHT and JPDA likelihood ratios.

`measurement_volume` is a sensor's coverage measured in its measurement
space, for a scan-wide density (contacts over the volume).

The density at a point is the number of the scan's contacts in the square of
half-side ``radius`` around it, over the square's area (at least one
contact, so a density is never zero). Counting uses a summed-area table on a
grid of radius/4 cells, so any number of query points costs O(1) each; the
square's edges are exact to an eighth of ``radius``, without bias. Given the
sensor, the area is only the square's part inside its coverage (found on a
grid of `_EDGE_POINTS`^2 points of the square): near the maximum range half
the square sees no clutter, and counting over the whole square halves the
density there, doubles every contact's likelihood ratio and lets a track
that follows the coverage edge on clutter alone confirm. That part is
tabulated once per coverage and radius on the counting grid's cells
(`_covered_table`, interpolated), so it too costs O(1) per query point.

Why compiled: every tracker under the score rule counts once
per scan, at ~100 contacts, and the numpy formulation spent ~110 us of a
~0.65 ms scan (the neural tracker's) in per-call overhead: the table's
cumulative sums, fancy indexing, the interpolation's dozen temporaries.
`_density` does the same arithmetic in one call, with integer counts: the
same densities to the bit (8 us at 100 contacts). A direct count per query
over binned contacts is a little faster at 100 (6 us) but grows with the
contacts per square (1.0 ms against the table's 0.16 ms at 5,000); the
table costs its grid (the points' extent over radius/4, squared) plus O(1)
per point (benchmarks/bench_trackers.py, part 0, prints the comparison).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np

from nnda.data.scenario import Sensor
from nnda.data.sensor import TWO_PI, cart_to_polar_at, in_coverage, wrap_angle

#: grid cells per ``radius``
_CELLS = 4
#: points per side of the grid on which the part of a square inside the coverage is measured
_EDGE_POINTS = 16
#: `_density`'s covered-part table without a sensor (every square wholly covered), and its corner
_NO_TABLE, _NO_CORNER = np.empty((0, 0)), np.zeros(2)
_jit = numba.njit(cache=True, nogil=True, error_model="numpy")  # x / 0 gives inf or NaN, as numpy


def coverage_area(sensor: Sensor) -> float:
    """The sensor's coverage (its ring, or its sector of the ring) in m^2."""
    return 0.5 * TWO_PI * (sensor.fov_deg / 360.0) * (sensor.max_range_m**2 - sensor.min_range_m**2)


def measurement_volume(sensor: Sensor) -> float:
    """The sensor's coverage in its measurement space: (r_max - r_min) x sector (m rad) for a polar
    sensor, its area (m^2) for a position sensor."""
    if sensor.kind == "polar":
        return (sensor.max_range_m - sensor.min_range_m) * TWO_PI * (sensor.fov_deg / 360.0)
    return coverage_area(sensor)


def local_density(contacts: np.ndarray, at: np.ndarray, radius: float, sensor: Sensor | None = None
                  ) -> np.ndarray:
    """Contacts per m^2 around each point of ``at`` (Q, 2); ``contacts`` (N, 2) in m, all of one scan of
    ``sensor`` when given (the area is then the square's part inside its coverage). Returns (Q,)."""
    radius = float(radius)
    table, corner = (_NO_TABLE, _NO_CORNER) if sensor is None else _covered_table(sensor, radius)
    return _density(np.ascontiguousarray(contacts, np.float64), np.ascontiguousarray(at, np.float64), radius,
                    table, corner)


@_jit
def _density(contacts, at, radius, table, corner):
    """`local_density`: contacts (N, 2) and points at (Q, 2) in m, the square's half-side ``radius`` m, the
    covered-part table (n, n) of `_covered_table` and its lower corner (2,) m, or a (0, 0) table for
    squares wholly covered. Returns (Q,) m^-2.

    The counting grid has cells of radius/4 from ``lo``, the points' lower corner less radius and a cell;
    contact i lies in cell floor((c_i - lo) / cell), and the square around a point covers cells [a, b),
    a = rint((at - radius - lo) / cell), b = rint((at + radius - lo) / cell) (its edges to half a cell).
    """
    N, Q = contacts.shape[0], at.shape[0]
    cell = radius / _CELLS
    side = (2.0 * radius) ** 2
    out = np.empty(Q)
    if N == 0 or Q == 0:
        for q in range(Q):
            out[q] = 1.0 / (side * _covered(at[q, 0], at[q, 1], table, corner, cell))
        return out
    lo0, lo1 = min(contacts[0, 0], at[0, 0]), min(contacts[0, 1], at[0, 1])
    hi0, hi1 = max(contacts[0, 0], at[0, 0]), max(contacts[0, 1], at[0, 1])
    for points in (contacts, at):
        for i in range(points.shape[0]):
            lo0, hi0 = min(lo0, points[i, 0]), max(hi0, points[i, 0])
            lo1, hi1 = min(lo1, points[i, 1]), max(hi1, points[i, 1])
    lo0, lo1 = lo0 - radius - cell, lo1 - radius - cell
    n0 = int(math.ceil((hi0 + radius + cell - lo0) / cell)) + 1
    n1 = int(math.ceil((hi1 + radius + cell - lo1) / cell)) + 1
    table_sum = np.zeros((n0 + 1, n1 + 1), np.int64)  # [i, j]: the contacts in cells [0, i) x [0, j)
    for i in range(N):
        table_sum[int((contacts[i, 0] - lo0) // cell) + 1, int((contacts[i, 1] - lo1) // cell) + 1] += 1
    for i in range(1, n0 + 1):
        row = 0
        for j in range(1, n1 + 1):
            row += table_sum[i, j]
            table_sum[i, j] = table_sum[i - 1, j] + row
    for q in range(Q):
        x, y = at[q, 0], at[q, 1]
        a0, b0 = int(np.rint((x - radius - lo0) / cell)), int(np.rint((x + radius - lo0) / cell))
        a1, b1 = int(np.rint((y - radius - lo1) / cell)), int(np.rint((y + radius - lo1) / cell))
        n = table_sum[b0, b1] - table_sum[a0, b1] - table_sum[b0, a1] + table_sum[a0, a1]
        out[q] = max(float(n), 1.0) / (side * _covered(x, y, table, corner, cell))
    return out


@_jit
def _covered(x, y, table, corner, cell):
    """`covered_fraction` at the point (x, y) m, interpolated bilinearly between the centres of the cells
    (side ``cell`` m, from ``corner``) of `_covered_table`'s ``table`` (n, n), clamped to its edge cells;
    1 for a (0, 0) table."""
    if table.shape[0] == 0:
        return 1.0
    last = table.shape[0] - 2
    u, v = (x - corner[0]) / cell - 0.5, (y - corner[1]) / cell - 0.5
    a, b = min(max(int(math.floor(u)), 0), last), min(max(int(math.floor(v)), 0), last)
    wa, wb = min(max(u - a, 0.0), 1.0), min(max(v - b, 0.0), 1.0)
    return ((1 - wa) * ((1 - wb) * table[a, b] + wb * table[a, b + 1])
            + wa * ((1 - wb) * table[a + 1, b] + wb * table[a + 1, b + 1]))


def covered_fraction(sensor: Sensor, at: np.ndarray, radius: float) -> np.ndarray:
    """The part (0, 1] of the square of half-side ``radius`` (m) around each point of ``at`` (Q, 2) inside
    ``sensor``'s coverage, on a grid of `_EDGE_POINTS`^2 points (at least one point's share). Returns (Q,)."""
    fraction = np.ones(len(at))
    # only squares within their half-diagonal of the coverage's edges can reach outside it
    r, azimuth = cart_to_polar_at(sensor.position, at[:, 0], at[:, 1])
    reach = np.sqrt(2.0) * radius
    near = (r - reach < sensor.min_range_m) | (r + reach > sensor.max_range_m)
    if not sensor.full_circle:
        near |= (r <= reach) | (np.abs(wrap_angle(azimuth - sensor.boresight_rad))
                                > sensor.half_fov_rad - np.arcsin(np.minimum(reach / np.maximum(r, reach), 1.0)))
    near = np.flatnonzero(near)
    if not near.size:
        return fraction
    u = radius * ((np.arange(_EDGE_POINTS) + 0.5) * (2.0 / _EDGE_POINTS) - 1.0)
    x = at[near, :1, None] + u[None, :, None]  # (Q, E, 1)
    y = at[near, 1:, None] + u[None, None, :]  # (Q, 1, E)
    inside = in_coverage(sensor, *np.broadcast_arrays(x, y))
    fraction[near] = np.maximum(inside.mean(axis=(1, 2)), 1.0 / _EDGE_POINTS**2)
    return fraction


#: the sensor fields its coverage depends on (`in_coverage`)
_COVERAGE_FIELDS = ("x_m", "y_m", "boresight_deg", "fov_deg", "min_range_m", "max_range_m")


def _covered_table(sensor: Sensor, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """`covered_fraction` at the centres of the radius/_CELLS cells over the sensor's coverage and a radius
    around it: (the table (n, n), its lower corner (2,) m). Cached by the coverage alone: sensors that differ
    only in noise, clutter or timing (S1-S6's radars) share one table, which costs ~0.1 s to build."""
    return _coverage_table(tuple(getattr(sensor, f) for f in _COVERAGE_FIELDS), float(radius))


@lru_cache(maxsize=32)
def _coverage_table(coverage: tuple[float, ...], radius: float) -> tuple[np.ndarray, np.ndarray]:
    """`_covered_table` of the sensor with the coverage ``coverage`` (the values of `_COVERAGE_FIELDS`)."""
    sensor = Sensor(**dict(zip(_COVERAGE_FIELDS, coverage, strict=True)))
    cell = radius / _CELLS
    lo = np.asarray(sensor.position, float) - sensor.max_range_m - radius
    n = int(np.ceil(2.0 * (sensor.max_range_m + radius) / cell))
    centre = lo[:, None] + (np.arange(n) + 0.5) * cell  # (2, n)
    gx, gy = np.meshgrid(centre[0], centre[1], indexing="ij")
    return covered_fraction(sensor, np.column_stack([gx.ravel(), gy.ravel()]), radius).reshape(n, n), lo
