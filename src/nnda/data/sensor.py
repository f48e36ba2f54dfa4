"""The radar: polar geometry, measurement noise and coverage (spec §2).

Frame (conventions.md): radar at the origin, x east, y north, metres. A polar
measurement is (range r in m, azimuth theta in rad clockwise from north):
x = r sin(theta), y = r cos(theta), theta = atan2(x, y). Stored azimuths lie
in [0, 2 pi); residuals are wrapped to [-pi, pi) with `wrap_angle`.
"""

from __future__ import annotations

import numpy as np

from nnda.data.scenario import Sensor

TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles (rad) to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % TWO_PI - np.pi


def cart_to_polar(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) in m -> (range m, azimuth rad in [0, 2 pi), clockwise from north)."""
    return np.hypot(x, y), np.arctan2(x, y) % TWO_PI


def polar_to_cart(r: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(range m, azimuth rad clockwise from north) -> (x east, y north) in m."""
    return r * np.sin(theta), r * np.cos(theta)


def in_coverage(sensor: Sensor, r: np.ndarray) -> np.ndarray:
    """Boolean mask of ranges inside [min_range, max_range]."""
    return (r >= sensor.min_range_m) & (r <= sensor.max_range_m)


def measure(
    sensor: Sensor, x: np.ndarray, y: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Noisy polar measurements of true positions (m); returns (range m, azimuth rad).

    Range and azimuth get independent zero-mean Gaussian noise of std
    ``sigma_range_m`` and ``sigma_azimuth_mrad`` (spec eqs. 5.1-5.3).
    """
    r, theta = cart_to_polar(np.asarray(x, float), np.asarray(y, float))
    noise = rng.standard_normal((2, r.size)).reshape((2, *r.shape))
    return r + sensor.sigma_range_m * noise[0], (theta + sensor.sigma_azimuth_rad * noise[1]) % TWO_PI
