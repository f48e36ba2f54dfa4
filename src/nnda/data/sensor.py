"""Sensors: polar geometry about a sensor's position, coverage and measurement noise.

Frame: x east, y north, metres; the radar of Vargas Avila (2015) sits at
the origin, other sensors at their configured positions. A polar
measurement is (range r in m, azimuth theta in rad clockwise from north)
from the sensor: x - x_s = r sin(theta), y - y_s = r cos(theta),
theta = atan2(x - x_s, y - y_s). Stored azimuths lie in [0, 2 pi); residuals
are wrapped to [-pi, pi) with `wrap_angle`. `cart_to_polar` and
`polar_to_cart` are the transforms about the origin, the ``_at`` forms about
a sensor position; at the origin those return exactly what the origin forms
do (no arithmetic is added).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nnda.data.scenario import Sensor

TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles (rad) to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % TWO_PI - np.pi


def wrap_azimuth(a: np.ndarray | float) -> np.ndarray | float:
    """Azimuths (rad) in [0, 2 pi): modulo 2 pi, and a tiny negative angle, which the modulo rounds to 2 pi
    itself, to 0."""
    a = np.mod(a, TWO_PI)
    return a - TWO_PI * (a >= TWO_PI)  # exact: 2 pi - 2 pi = 0, a - 0 = a; a scalar stays a scalar


def cart_to_polar(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) in m -> (range m, azimuth rad in [0, 2 pi), clockwise from north), about the origin."""
    return np.hypot(x, y), wrap_azimuth(np.arctan2(x, y))


def polar_to_cart(r: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(range m, azimuth rad clockwise from north) about the origin -> (x east, y north) in m."""
    return r * np.sin(theta), r * np.cos(theta)


def cart_to_polar_at(origin: tuple[float, float], x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (x, y) in m, scenario frame -> (range m, azimuth rad in [0, 2 pi)) from ``origin`` (m)."""
    ox, oy = origin
    if ox == 0.0 and oy == 0.0:
        return cart_to_polar(x, y)
    return cart_to_polar(np.subtract(x, ox), np.subtract(y, oy))


def polar_to_cart_at(origin: tuple[float, float], r: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(range m, azimuth rad) from ``origin`` (m) -> positions (x, y) in m, scenario frame."""
    x, y = polar_to_cart(r, theta)
    ox, oy = origin
    if ox == 0.0 and oy == 0.0:
        return x, y
    return x + ox, y + oy


def in_coverage_polar(sensor: Sensor, r: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """Boolean mask of sensor-relative (range m, azimuth rad) inside the sensor's range limits and sector."""
    inside = (r >= sensor.min_range_m) & (r <= sensor.max_range_m)
    if sensor.full_circle:
        return inside
    return inside & (np.abs(wrap_angle(np.asarray(azimuth) - sensor.boresight_rad)) <= sensor.half_fov_rad)


def in_coverage(sensor: Sensor, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Boolean mask of positions (x, y in m, scenario frame) inside the sensor's coverage."""
    return in_coverage_polar(sensor, *cart_to_polar_at(sensor.position, x, y))


def observable(sensors: Sequence[Sensor], sweeping: int, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Boolean mask of positions (x, y in m, shape (K,)) that a scan of ``sensors[sweeping]`` should be held
    to: inside its coverage, or outside every one of ``sensors`` (an object nobody sees still misses)."""
    inside = np.array([in_coverage(s, x, y) for s in sensors])  # (sensors, K)
    return inside[sweeping] | ~inside.any(axis=0)


def measure(
    sensor: Sensor, x: np.ndarray, y: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Noisy measurements of true positions (x, y in m, scenario frame, any shape) by ``sensor``.

    Polar sensor: (range m, azimuth rad in [0, 2 pi)) from the sensor, with
    independent zero-mean Gaussian noise of std ``sigma_range_m`` and
    ``sigma_azimuth_mrad`` (Vargas Avila (2015), eqs. 5.1-5.3). Position sensor: (x m, y m)
    with std ``sigma_position_m`` per axis. Draws one (2, size) standard
    normal block from ``rng`` in both cases.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    noise = rng.standard_normal((2, x.size)).reshape((2, *x.shape))
    if sensor.kind == "position":
        return x + sensor.sigma_position_m * noise[0], y + sensor.sigma_position_m * noise[1]
    r, theta = cart_to_polar_at(sensor.position, x, y)
    return r + sensor.sigma_range_m * noise[0], wrap_azimuth(theta + sensor.sigma_azimuth_rad * noise[1])
