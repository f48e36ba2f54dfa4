"""Clutter: false contacts per sweep of one sensor.

Vargas Avila (2015) gives the count (100 per scan) but not where the points
lie; the laws are ours, the default square sized so that the 17 training
scenes give about the thesis's 1935 clutter pairs.

Points are drawn in Cartesian coordinates (scenario frame, m) and redrawn
until they lie inside the sensor's coverage, so the count per sweep is exact
(dropping them instead would lower the clutter-pair count by about 2%). The
generator's plan has checked that at least `nnda.data.checks.MIN_CLUTTER_INSIDE`
of the region lies inside the coverage (`nnda.data.checks.check_clutter`), so the redrawing ends.
"""

from __future__ import annotations

import numpy as np

from nnda.data.checks import MIN_CLUTTER_INSIDE
from nnda.data.scenario import Clutter, Sensor
from nnda.data.sensor import TWO_PI, in_coverage, polar_to_cart_at

_MIN_BATCH = 256
_MAX_BATCH = 1 << 20  # points drawn at once: bounds the memory of a sparsely covered region (~50 MB)


def clutter_counts(clutter: Clutter, n_sweeps: int, rng: np.random.Generator) -> np.ndarray:
    """Number of clutter points in each of a sensor's sweeps, shape (n_sweeps,), int64."""
    if clutter.law == "none" or clutter.count == 0:
        return np.zeros(n_sweeps, dtype=np.int64)
    if clutter.count_law == "poisson":
        return rng.poisson(clutter.count, n_sweeps).astype(np.int64)
    return np.full(n_sweeps, clutter.count, dtype=np.int64)


def _draw(clutter: Clutter, sensor: Sensor, centre: np.ndarray, n: int, rng: np.random.Generator):
    if clutter.law == "annulus":  # uniform in area over the ring, or over its sector
        r2 = rng.uniform(sensor.min_range_m**2, sensor.max_range_m**2, n)
        if sensor.full_circle:
            theta = rng.uniform(0.0, TWO_PI, n)
        else:
            b, h = sensor.boresight_rad, sensor.half_fov_rad
            theta = rng.uniform(b - h, b + h, n)
        return polar_to_cart_at(sensor.position, np.sqrt(r2), theta)
    if clutter.law == "square":
        xy = rng.uniform(-0.5, 0.5, (n, 2)) * clutter.side_m + centre
    else:  # gaussian
        xy = rng.standard_normal((n, 2)) * clutter.sigma_m + centre
    return xy[:, 0], xy[:, 1]


def clutter_positions(
    clutter: Clutter, sensor: Sensor, centre: np.ndarray, total: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """``total`` clutter positions (x, y in m, scenario frame, shapes (total,)), each inside the coverage.

    ``centre`` (2,) is the square's or the Gaussian's centre in m; the region
    must meet the coverage (`nnda.data.checks.check_clutter`).
    """
    xs, ys, have, drawn, accepted = [np.empty(0)], [np.empty(0)], 0, 0, 0
    while have < total:
        rate = accepted / drawn if drawn else 1.0
        batch = min(_MAX_BATCH, max(_MIN_BATCH, int(1.2 * (total - have) / max(rate, MIN_CLUTTER_INSIDE))))
        x, y = _draw(clutter, sensor, centre, batch, rng)
        keep = in_coverage(sensor, x, y)
        drawn += batch
        accepted += int(keep.sum())
        xs.append(x[keep])
        ys.append(y[keep])
        have += int(keep.sum())
    return np.concatenate(xs)[:total], np.concatenate(ys)[:total]
