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
tabulated per coverage and radius on the counting grid's cells
(interpolated), so it too costs O(1) per query point; the table is filled
lazily, a cell the first time a query point needs it (`_covered_cells`,
`_fill`), so a tracker's first scan costs its contacts' cells, not the
coverage's (a 400 km radar's whole table took about 5 s and 2 GiB; its first
scan's cells take milliseconds and a zeroed table of 4 bytes a cell:
benchmarks/bench_coverage_table.py). A cell's value is the same number
either way, computed by `covered_fraction` at its centre (`_covered_table`
tabulates every cell at once, the reference).

Why compiled: every tracker under the score rule counts once
per scan, at ~100 contacts, and the numpy formulation spent ~110 us of a
~0.65 ms scan (the neural tracker's) in per-call overhead: the table's
cumulative sums, fancy indexing, the interpolation's dozen temporaries.
`_density` does the same arithmetic in one call, its counts whole numbers (exact in float64): the
same densities to the bit (8 us at 100 contacts). A direct count per query
over binned contacts is a little faster at 100 (6 us) but grows with the
contacts per square (1.0 ms against the table's 0.16 ms at 5,000); the
table costs its grid (the points' extent over radius/4, squared) plus O(1)
per point (benchmarks/bench_trackers.py, part 0, prints the comparison):
a scan whose grid holds far more cells than points (a wide coverage: 1.1
million cells at 400 km) is counted by strips instead (`_square_sums`),
the same integer counts at a cost that does not grow with the extent.

`unexplained_density` counts the same squares, but leaves out what the
tracks explain: the query's own contact, and each track's expected
detections (P_D P_G r) at its predicted position, a weighted count on the
same grid (Musicki & Evans 2004 estimate a scan's clutter count as its
contacts less the tracks' expected detections; here per square, in the
manner of a spatial clutter map, Nitzberg 1972, but of one scan), floored
by that scan-wide estimate over the coverage. Where targets are dense, the
count above counts their own contacts as clutter (and every contact counts
itself: at least one contact a square, far above a sparse clutter's
density), so their likelihood ratios fall and confirmation comes late.
"""

from __future__ import annotations

import math
from functools import lru_cache
from operator import attrgetter

import numba
import numpy as np

from nnda.data.scenario import Sensor
from nnda.data.sensor import TWO_PI, cart_to_polar_at, in_coverage, wrap_angle

#: grid cells per ``radius``
_CELLS = 4
#: `_density` counts over a summed-area table of its grid unless the grid has more than _STRIP_GRID cells a
#: point (contacts and query points) and _STRIP_FLOOR: then by strips (`_square_sums`), whose cost does not
#: grow with the points' extent (a 400 km radar's scan: a grid of 1.1 million cells, 9 MB, a call)
_STRIP_GRID, _STRIP_FLOOR = 64, 16_384
#: points per side of the grid on which the part of a square inside the coverage is measured
_EDGE_POINTS = 16
#: `_density`'s covered-part table without a sensor (every square wholly covered), and its corner
_NO_TABLE, _NO_CORNER = np.empty((0, 0), np.float32), np.zeros(2)  # float32: the type of a sensor's table
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
    contacts, at = np.ascontiguousarray(contacts, np.float64), np.ascontiguousarray(at, np.float64)
    return _counted(_density, sensor, contacts, at, radius, -1)  # -1 given: one signature


def unexplained_density(contacts: np.ndarray, at: np.ndarray, radius: float, scan_area: float,
                        sensor: Sensor | None = None, explained: np.ndarray | None = None,
                        expected: np.ndarray | None = None, own: float | np.ndarray = 0.0) -> np.ndarray:
    """Clutter per m^2 around each point of ``at`` (Q, 2) m, counting only the contacts (N, 2) m that the
    tracks do not explain: the contacts in the square of half-side ``radius`` m (as `local_density`), less
    ``own`` (a number or (Q,): the query's own contacts, which are not a sample of the clutter around them:
    1 at a contact of the scan), less the expected detections ``expected`` (K,) of the tracks predicted at
    ``explained`` (K, 2) m whose positions lie in the square (P_D P_G r of each: Musicki & Evans 2004's
    clutter count, the contacts less the tracks' expected detections, here per square), at least 0, over the
    square's area (its part inside ``sensor``'s coverage when given); and at least the scan's clutter
    density: its contacts less every track's expected detections (at least one) over ``scan_area`` m^2, so
    an empty square is not read as no clutter. Costs O(1) per point and O(N + K) to count. Returns (Q,)."""
    radius = float(radius)
    contacts, at = np.ascontiguousarray(contacts, np.float64), np.ascontiguousarray(at, np.float64)
    explained = np.ascontiguousarray(np.empty((0, 2)) if explained is None else explained, np.float64)
    expected = np.ascontiguousarray(np.empty(0) if expected is None else expected, np.float64)
    own = np.array(np.broadcast_to(np.asarray(own, np.float64), (len(at),)))  # a copy: never a read-only view
    return _counted(_unexplained, sensor, contacts, at, radius, explained, expected, own, float(scan_area))


def _counted(kernel, sensor: Sensor | None, contacts: np.ndarray, at: np.ndarray, radius: float, *rest) -> np.ndarray:
    """``kernel`` (`_density` or `_unexplained`) of the ``contacts`` around the points ``at`` in squares of half-side
    ``radius`` (its further arguments ``rest``) over ``sensor``'s lazily filled covered-part table (without a
    sensor the empty table: every square wholly covered); where the kernel finds cells its points read not
    computed yet (a scan's first look at a part of the coverage), they are filled (`_fill`) and it runs again."""
    if sensor is None:
        return kernel(contacts, at, radius, _NO_TABLE, _NO_CORNER, *rest)[0]
    table, corner, coverage = _covered_cells(sensor, radius)
    out, missing = kernel(contacts, at, radius, table, corner, *rest)
    if missing.shape[0]:
        _fill(coverage, table, corner, missing, radius)
        out = kernel(contacts, at, radius, table, corner, *rest)[0]
    return out


@_jit
def _density(contacts, at, radius, table, corner, strips=-1):
    """`local_density`: contacts (N, 2) and points at (Q, 2) in m, the square's half-side ``radius`` m, the
    covered-part table (n, n) of `_covered_table` and its lower corner (2,) m, or a (0, 0) table for
    squares wholly covered; counted by `_square_sums`, over the grid's summed-area table or by strips:
    ``strips`` 0 or 1, or -1 (the default) by the grid's size. Returns (Q,) m^-2 and no cells (0, 2); or, where the
    points read cells of the table not computed yet, no densities and those cells (`_missing`)."""
    N, Q = contacts.shape[0], at.shape[0]
    cell = radius / _CELLS
    side = (2.0 * radius) ** 2
    missing = _missing(at, table, corner, cell)
    if missing.shape[0]:
        return np.empty(0), missing
    out = np.empty(Q)
    if N == 0 or Q == 0:
        for q in range(Q):
            out[q] = 1.0 / (side * _covered(at[q, 0], at[q, 1], table, corner, cell))
        return out, missing
    lo0, lo1, n0, n1 = _grid(contacts, at, radius)
    wide = strips == 1 or (strips == -1 and n0 * n1 > _STRIP_GRID * (N + Q) + _STRIP_FLOOR)
    n = _square_sums(contacts, np.ones(N), at, radius, lo0, lo1, n0, n1, wide)
    for q in range(Q):
        out[q] = max(n[q], 1.0) / (side * _covered(at[q, 0], at[q, 1], table, corner, cell))
    return out, missing


@_jit
def _unexplained(contacts, at, radius, table, corner, explained, expected, own, scan_area):
    """`unexplained_density` (its arguments, the covered-part table and corner as `_density`'s), the sums
    by `_square_sums` over the grid of the contacts and points (tracks outside it are in no square).
    Returns (Q,) m^-2 and the table's cells not computed yet, as `_density`."""
    N, Q = contacts.shape[0], at.shape[0]
    cell = radius / _CELLS
    side = (2.0 * radius) ** 2
    floor = max(N - expected.sum(), 1.0) / scan_area
    missing = _missing(at, table, corner, cell)
    if missing.shape[0]:
        return np.empty(0), missing
    out = np.empty(Q)
    if Q == 0:
        return out, missing
    lo0, lo1, n0, n1 = _grid(contacts, at, radius)
    wide = n0 * n1 > _STRIP_GRID * (N + Q + explained.shape[0]) + _STRIP_FLOOR
    n = _square_sums(contacts, np.ones(N), at, radius, lo0, lo1, n0, n1, wide)
    e = _square_sums(explained, expected, at, radius, lo0, lo1, n0, n1, wide)
    for q in range(Q):
        count = max(n[q] - own[q] - e[q], 0.0)
        out[q] = max(count / (side * _covered(at[q, 0], at[q, 1], table, corner, cell)), floor)
    return out, missing


@_jit
def _grid(contacts, at, radius):
    """The counting grid of the contacts (N, 2) and the points at (Q, 2) m (N + Q > 0): cells of radius/4 from
    (lo0, lo1), the points' lower corner less radius and a cell, n0 x n1 of them (every square inside)."""
    cell = radius / _CELLS
    first = contacts if contacts.shape[0] else at
    lo0, lo1, hi0, hi1 = first[0, 0], first[0, 1], first[0, 0], first[0, 1]
    for points in (contacts, at):
        for i in range(points.shape[0]):
            lo0, hi0 = min(lo0, points[i, 0]), max(hi0, points[i, 0])
            lo1, hi1 = min(lo1, points[i, 1]), max(hi1, points[i, 1])
    lo0, lo1 = lo0 - radius - cell, lo1 - radius - cell
    n0 = int(math.ceil((hi0 + radius + cell - lo0) / cell)) + 1
    n1 = int(math.ceil((hi1 + radius + cell - lo1) / cell)) + 1
    return lo0, lo1, n0, n1


@_jit
def _square_sums(points, weights, at, radius, lo0, lo1, n0, n1, strips):
    """The weights (N,) of the points (N, 2) m in the square around each point of at (Q, 2) m, summed (Q,):
    on the grid of `_grid` (n0 x n1 cells of radius/4 from (lo0, lo1); points outside it are in no square),
    point i in cell floor((p_i - lo) / cell), the square around a point the cells [a, b), a = rint((at -
    radius - lo) / cell), b = rint((at + radius - lo) / cell) (its edges to half a cell). Summed over the
    grid's summed-area table, or, with ``strips`` (a grid far larger than its points: a wide coverage),
    column by column of [a0, b0) over the points sorted by cell key (`sorted_cells`, each column's run of
    cells found by bisection, the weights' running sums), O((N + Q) log N) whatever the grid. Integer
    weights give the same sums either way, to the bit."""
    Q = at.shape[0]
    cell = radius / _CELLS
    ix, iy = contact_cells(points, lo0, lo1, cell)
    inside = np.flatnonzero((ix >= 0) & (ix < n0) & (iy >= 0) & (iy < n1))
    out = np.zeros(Q)
    if strips:
        order, keys = sorted_cells(points[inside], lo0, lo1, cell, n1)
        running = np.zeros(inside.size + 1)
        running[1:] = np.cumsum(weights[inside][order])
        for q in range(Q):
            a0, b0, a1, b1 = square_cells(at[q, 0], at[q, 1], radius, lo0, lo1, cell)
            for column in range(a0, b0):
                start, stop = key_range(keys, column, a1, b1 - 1, n1)
                out[q] += running[stop] - running[start]
        return out
    table_sum = np.zeros((n0 + 1, n1 + 1))  # [i, j]: the weights in cells [0, i) x [0, j)
    for i in inside:
        table_sum[ix[i] + 1, iy[i] + 1] += weights[i]
    for i in range(1, n0 + 1):
        row = 0.0
        for j in range(1, n1 + 1):
            row += table_sum[i, j]
            table_sum[i, j] = table_sum[i - 1, j] + row
    for q in range(Q):
        a0, b0, a1, b1 = square_cells(at[q, 0], at[q, 1], radius, lo0, lo1, cell)
        out[q] = table_sum[b0, b1] - table_sum[a0, b1] - table_sum[b0, a1] + table_sum[a0, a1]
    return out


@_jit
def contact_cells(contacts, lo0, lo1, cell):
    """The counting grid's cell of each contact (N, 2) m, cells of ``cell`` m from (lo0, lo1) m: (ix (N,), iy (N,)),
    floor((c - lo) / cell)."""
    N = contacts.shape[0]
    ix, iy = np.empty(N, np.int64), np.empty(N, np.int64)
    for i in range(N):
        ix[i], iy[i] = int((contacts[i, 0] - lo0) // cell), int((contacts[i, 1] - lo1) // cell)
    return ix, iy


#: grids over a scan's own points (`sorted_cells`, the initiation's window pairs) double their cells until neither
#: axis has more than this many: a point's cell index, floor((p - lo) / cell), then stays far from float rounding (a
#: point within a cell side of another is always in a neighbouring cell) and a cell key ix n1 + iy far from int64's
#: range
MAX_CELLS_PER_AXIS = 2.0**26


@_jit
def sorted_cells(points, lo0, lo1, cell, n1):
    """The points (N, 2) m bucketed in the grid of `contact_cells` (cells of ``cell`` m from (lo0, lo1) m, ``n1``
    along y, every point's iy in [0, n1)) by a cell key ix n1 + iy: (order (N,), the points sorted by key, stable
    within a cell; keys (N,) int64, ascending). The points of the cells (ix, a1..b1) are those of the keys
    [ix n1 + a1, ix n1 + b1], found by bisection: no table of cells, so the cost does not grow with the grid."""
    ix, iy = contact_cells(points, lo0, lo1, cell)
    key = ix * n1 + iy
    order = np.argsort(key, kind="mergesort")
    return order, key[order]


@_jit
def key_range(keys, column, a1, b1, n1):
    """The positions [start, stop) in the ascending ``keys`` of `sorted_cells` of the points in the cells (column,
    a1..b1) (inclusive; a1, b1 clamped to [0, n1); empty when a1 > b1 after it)."""
    a1, b1 = max(a1, 0), min(b1, n1 - 1)
    if a1 > b1:
        return 0, 0
    return np.searchsorted(keys, column * n1 + a1), np.searchsorted(keys, column * n1 + b1 + 1)


@_jit
def square_cells(x, y, radius, lo0, lo1, cell):
    """The cells [a0, b0) x [a1, b1) of the counting grid (cells of ``cell`` m from (lo0, lo1) m) that the square of
    half-side ``radius`` m around (x, y) m covers, its edges to half a cell: a = rint((at - radius - lo) / cell),
    b = rint((at + radius - lo) / cell)."""
    return (int(np.rint((x - radius - lo0) / cell)), int(np.rint((x + radius - lo0) / cell)),
            int(np.rint((y - radius - lo1) / cell)), int(np.rint((y + radius - lo1) / cell)))


@_jit
def _cell_of(x, y, table, corner, cell):
    """The lower of the two cells per axis between whose centres `_covered` interpolates at (x, y) m, and
    the weights of the upper ones: (a, b, wa, wb)."""
    last = table.shape[0] - 2
    u, v = (x - corner[0]) / cell - 0.5, (y - corner[1]) / cell - 0.5
    a, b = min(max(int(math.floor(u)), 0), last), min(max(int(math.floor(v)), 0), last)
    return a, b, min(max(u - a, 0.0), 1.0), min(max(v - b, 0.0), 1.0)


@_jit
def _missing(at, table, corner, cell):
    """The cells (M, 2) of a lazily filled table (0: not computed yet) that `_covered` reads at the points
    ``at`` (Q, 2) m and that are not computed yet (a cell that two points read: twice). The table is not
    written here: a cell, once set, only ever holds its one value, so concurrent callers at worst compute a
    cell twice."""
    out = np.empty((4 * at.shape[0], 2), np.int64)
    m = 0
    if table.shape[0] == 0:
        return out[:0]
    for q in range(at.shape[0]):
        a, b, _, _ = _cell_of(at[q, 0], at[q, 1], table, corner, cell)
        for i in range(a, a + 2):
            for j in range(b, b + 2):
                if table[i, j] == 0.0:
                    out[m, 0], out[m, 1] = i, j
                    m += 1
    return out[:m]


@_jit
def _covered(x, y, table, corner, cell):
    """`covered_fraction` at the point (x, y) m, interpolated bilinearly between the centres of the cells
    (side ``cell`` m, from ``corner``) of `_covered_table`'s ``table`` (n, n), clamped to its edge cells;
    1 for a (0, 0) table."""
    if table.shape[0] == 0:
        return 1.0
    a, b, wa, wb = _cell_of(x, y, table, corner, cell)
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
#: their values as a tuple, in one call (every scan of a tracker under the score rule reads them twice)
_coverage_values = attrgetter(*_COVERAGE_FIELDS)


def _covered_table(sensor: Sensor, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """`covered_fraction` at the centres of the radius/_CELLS cells over the sensor's coverage and a radius
    around it: (the table (n, n), its lower corner (2,) m), every cell computed at once (the reference of the
    lazily filled table `local_density` reads, `_covered_cells`: its cells hold the same values). Cached by
    the coverage alone: sensors that differ only in noise, clutter or timing (S1-S6's radars) share one
    table, which costs ~0.1 s to build for S1-S6's 30 km radar, and grows with the coverage's area (1.3 s and
    0.5 GiB at 200 km)."""
    return _coverage_table(_coverage_of(sensor), float(radius))


def _coverage_of(sensor: Sensor) -> tuple[float, ...]:
    """The values of `_COVERAGE_FIELDS` of ``sensor``: what its coverage depends on."""
    return _coverage_values(sensor)


def _table_grid(sensor: Sensor, radius: float) -> tuple[np.ndarray, int]:
    """The covered-part table's lower corner (2,) m and side n (cells of radius/_CELLS): the sensor's coverage
    and a radius around it."""
    lo = np.asarray(sensor.position, float) - sensor.max_range_m - radius
    return lo, int(np.ceil(2.0 * (sensor.max_range_m + radius) / (radius / _CELLS)))


def _covered_cells(sensor: Sensor, radius: float) -> tuple[np.ndarray, np.ndarray, Sensor]:
    """The lazily filled covered-part table of ``sensor``'s coverage and ``radius``: (the table (n, n), zero
    where not computed yet (a covered part is at least 1/_EDGE_POINTS^2), float32, which holds its values
    k / _EDGE_POINTS^2 exactly; its lower corner (2,) m; a sensor of that coverage). Cached by the coverage
    alone, as `_covered_table`; the cache keeps at most 32 tables, each 4 bytes a cell (n = 8 (r_max + radius)
    / radius: 4.6 MB for a 400 km radar at 3 km) and the cells filled so far."""
    return _coverage_cells(_coverage_of(sensor), float(radius))


@lru_cache(maxsize=32)
def _coverage_cells(coverage: tuple[float, ...], radius: float) -> tuple[np.ndarray, np.ndarray, Sensor]:
    """`_covered_cells` of the sensor with the coverage ``coverage`` (the values of `_COVERAGE_FIELDS`)."""
    sensor = Sensor(**dict(zip(_COVERAGE_FIELDS, coverage, strict=True)))
    lo, n = _table_grid(sensor, radius)
    return np.zeros((n, n), np.float32), lo, sensor


def _fill(sensor: Sensor, table: np.ndarray, corner: np.ndarray, cells: np.ndarray, radius: float) -> None:
    """Compute the cells ``cells`` (M, 2) of ``sensor``'s lazily filled table ``table`` (corner ``corner``): the
    covered part at their centres, as `_coverage_table` computes it (the same arithmetic, point by point)."""
    centres = corner + (cells + 0.5) * (radius / _CELLS)
    table[cells[:, 0], cells[:, 1]] = covered_fraction(sensor, centres, radius)


@lru_cache(maxsize=32)
def _coverage_table(coverage: tuple[float, ...], radius: float) -> tuple[np.ndarray, np.ndarray]:
    """`_covered_table` of the sensor with the coverage ``coverage`` (the values of `_COVERAGE_FIELDS`)."""
    sensor = Sensor(**dict(zip(_COVERAGE_FIELDS, coverage, strict=True)))
    cell = radius / _CELLS
    lo, n = _table_grid(sensor, radius)
    centre = lo[:, None] + (np.arange(n) + 0.5) * cell  # (2, n)
    gx, gy = np.meshgrid(centre[0], centre[1], indexing="ij")
    return covered_fraction(sensor, np.column_stack([gx.ravel(), gy.ravel()]), radius).reshape(n, n), lo
