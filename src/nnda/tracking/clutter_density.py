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
tabulated once per sensor and radius on the counting grid's cells
(`_covered_table`, interpolated), so it too costs O(1) per query point.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from nnda.data.scenario import Sensor
from nnda.data.sensor import TWO_PI, cart_to_polar_at, in_coverage, wrap_angle

#: grid cells per ``radius``
_CELLS = 4
#: points per side of the grid on which the part of a square inside the coverage is measured
_EDGE_POINTS = 16


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
    area = (2.0 * radius) ** 2 * (np.ones(len(at)) if sensor is None else _covered_lookup(sensor, at, radius))
    if len(contacts) == 0 or len(at) == 0:
        return 1.0 / area
    cell = radius / _CELLS
    lo = np.minimum(contacts.min(axis=0), at.min(axis=0)) - radius - cell
    hi = np.maximum(contacts.max(axis=0), at.max(axis=0)) + radius + cell
    shape = np.ceil((hi - lo) / cell).astype(np.int64) + 1
    idx = ((contacts - lo) // cell).astype(np.int64)
    counts = np.zeros(shape)
    np.add.at(counts, (idx[:, 0], idx[:, 1]), 1.0)
    table = np.zeros(shape + 1)
    table[1:, 1:] = counts.cumsum(axis=0).cumsum(axis=1)
    a = np.rint((at - radius - lo) / cell).astype(np.int64)  # cells [a, b) cover the square
    b = np.rint((at + radius - lo) / cell).astype(np.int64)  # to half a cell at each edge
    n = table[b[:, 0], b[:, 1]] - table[a[:, 0], b[:, 1]] - table[b[:, 0], a[:, 1]] + table[a[:, 0], a[:, 1]]
    return np.maximum(n, 1.0) / area


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


@lru_cache(maxsize=32)
def _covered_table(sensor: Sensor, radius: float) -> tuple[np.ndarray, np.ndarray, float]:
    """`covered_fraction` at the centres of the radius/_CELLS cells over the sensor's coverage and a radius
    around it: (the table (n, n), its lower corner (2,) m, the cell side m)."""
    cell = radius / _CELLS
    lo = np.asarray(sensor.position, float) - sensor.max_range_m - radius
    n = int(np.ceil(2.0 * (sensor.max_range_m + radius) / cell))
    centre = lo[:, None] + (np.arange(n) + 0.5) * cell  # (2, n)
    gx, gy = np.meshgrid(centre[0], centre[1], indexing="ij")
    return covered_fraction(sensor, np.column_stack([gx.ravel(), gy.ravel()]), radius).reshape(n, n), lo, cell


def _covered_lookup(sensor: Sensor, at: np.ndarray, radius: float) -> np.ndarray:
    """`covered_fraction` of the points ``at`` (Q, 2), interpolated bilinearly between the centres of the
    table's cells (`_covered_table`)."""
    table, lo, cell = _covered_table(sensor, float(radius))
    p = (at - lo) / cell - 0.5
    i = np.clip(np.floor(p).astype(np.int64), 0, len(table) - 2)
    w = np.clip(p - i, 0.0, 1.0)
    (a, b), (wa, wb) = i.T, w.T
    return ((1 - wa) * ((1 - wb) * table[a, b] + wb * table[a, b + 1])
            + wa * ((1 - wb) * table[a + 1, b] + wb * table[a + 1, b + 1]))
