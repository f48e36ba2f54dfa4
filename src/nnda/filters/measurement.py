"""Measurement models: a radar's polar measurement (Vargas Avila (2015), eqs. 5.19-5.25) and a linear position fix.

Both work on batches: states (..., n) whose components 0 and 2 are the
Cartesian position (x east, y north, m, scenario frame), measurements
(..., 2). The polar measurement is z = (range m, azimuth rad clockwise from
north) from the radar at ``origin`` = (x_s, y_s), with
h(X) = (sqrt(dx^2 + dy^2), atan2(dx, dy)), dx = x - x_s, dy = y - y_s
(eqs. 5.19-5.22 with the radar at the origin); its azimuth residuals are
wrapped to [-pi, pi) by `nnda.data.sensor.wrap_angle`. With the origin at
(0, 0) no shift is computed, so the results are those of the radar at the
origin bit for bit. `measurement_model` gives the model of a scenario's
sensor of either kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar, Protocol

import numba
import numpy as np

from nnda.data.scenario import Sensor
from nnda.data.sensor import cart_to_polar, wrap_angle
from nnda.errors import FilterError
from nnda.validation import check_array, check_covariance, check_finite, check_positive


class MeasurementModel(Protocol):
    """What the filters need from a (2-D) measurement model."""

    dim: int

    @property
    def R(self) -> np.ndarray:
        """Measurement-noise covariance (2, 2)."""
        ...

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted measurements h(x) (..., 2) and the Jacobian H (..., 2, n)."""
        ...

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        """z - z_pred (..., 2), with angles wrapped where the measurement has them."""
        ...

    def position(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cartesian positions (..., 2) of measurements and their covariances (..., 2, 2)."""
        ...

    def cartesian(self, z: np.ndarray) -> np.ndarray:
        """Cartesian positions (..., 2) of measurements, m, scenario frame (`position` without covariances)."""
        ...

    def spread(self, z: np.ndarray, S: np.ndarray) -> np.ndarray:
        """A bound (..., ) in m^2 on the Cartesian variance, along any direction, of a measurement
        distribution of mean z (..., 2) and covariance S (..., 2, 2): the radius of a circle holding
        a gate of squared radius g is sqrt(g * spread)."""
        ...

    def area_jacobian(self, z: np.ndarray) -> np.ndarray:
        """|det d(x, y) / dz| (...,) at measurements z: an area density (m^-2) times it is the density in
        measurement space."""
        ...

    def validate(self, name: str, z: np.ndarray) -> None:
        """Raise FilterError unless every measurement in ``z`` (..., 2) is valid."""
        ...


def converted_covariance(
    r: np.ndarray, azimuth: np.ndarray, sigma_range: float, sigma_azimuth: float
) -> np.ndarray:
    """Covariance (..., 2, 2) of the Cartesian position of polar measurements.

    Linearised polar-to-Cartesian errors with the math angle phi = pi/2 - azimuth:
    sigma_x^2 (eq. 5.44), sigma_y^2 (its mirror) and
    sigma_xy^2 = (sigma_d^2 - sigma_theta^2 d^2) cos phi sin phi (eq. 5.46 with
    d^2 where the thesis prints d, as the units require). ``r`` m, ``azimuth`` rad.
    """
    r = np.asarray(r, dtype=float)
    phi = 0.5 * np.pi - np.asarray(azimuth, dtype=float)
    c, s = np.cos(phi), np.sin(phi)
    var_d = sigma_range**2
    var_cross = sigma_azimuth**2 * r * r
    cov = np.empty((*np.broadcast(r, phi).shape, 2, 2))
    cov[..., 0, 0] = var_d * c * c + var_cross * s * s
    cov[..., 1, 1] = var_d * s * s + var_cross * c * c
    cov[..., 0, 1] = cov[..., 1, 0] = (var_d - var_cross) * c * s
    return cov


@numba.njit(cache=True, nogil=True)
def _positions(z, ox, oy, var_range, var_azimuth):
    """`PolarMeasurement.position` of N measurements z (N, 2) [range m, azimuth rad] from (ox, oy) m, with
    sigma_range^2 ``var_range`` and sigma_azimuth^2 ``var_azimuth``: positions (N, 2) m and covariances
    (N, 2, 2), with the operations of `polar_to_cart_at` (no shift at the origin) and `converted_covariance`."""
    return _cartesian(z, ox, oy), converted_covariances(z, var_range, var_azimuth)


@numba.njit(cache=True, nogil=True)
def converted_covariances(z, var_range, var_azimuth):
    """`converted_covariance`'s arithmetic, compiled: the Cartesian covariances (N, 2, 2) m^2 of N polar
    measurements z (N, 2) [range m, azimuth rad] with sigma_range^2 ``var_range`` and sigma_azimuth^2
    ``var_azimuth``."""
    n = z.shape[0]
    cov = np.empty((n, 2, 2))
    for i in range(n):
        r, azimuth = z[i, 0], z[i, 1]
        phi = 0.5 * math.pi - azimuth
        c, s = math.cos(phi), math.sin(phi)
        var_cross = var_azimuth * r * r
        cov[i, 0, 0] = var_range * c * c + var_cross * s * s
        cov[i, 1, 1] = var_range * s * s + var_cross * c * c
        cov[i, 0, 1] = cov[i, 1, 0] = (var_range - var_cross) * c * s
    return cov


@numba.njit(cache=True, nogil=True)
def _cartesian(z, ox, oy):
    """`PolarMeasurement.cartesian` of N measurements z (N, 2) [range m, azimuth rad] from (ox, oy) m:
    positions (N, 2) m, with the operations of `polar_to_cart_at` (no shift at the origin) in one compiled
    loop (every scan of every tracker converts its contacts)."""
    xy = np.empty((z.shape[0], 2))
    shifted = ox != 0.0 or oy != 0.0
    for i in range(z.shape[0]):
        x, y = z[i, 0] * math.sin(z[i, 1]), z[i, 0] * math.cos(z[i, 1])
        xy[i, 0], xy[i, 1] = (x + ox, y + oy) if shifted else (x, y)
    return xy


#: signs of the azimuth's gradient (py, -px) / r^2 from (py, px)
_AZIMUTH_SIGN = np.array([1.0, -1.0])


@dataclass(frozen=True)
class PolarMeasurement:
    """Range and azimuth from a radar at ``origin`` (m, scenario frame; default the origin).

    ``sigma_range`` m and ``sigma_azimuth`` rad give R = diag(sigma_range^2,
    sigma_azimuth^2) (eq. 5.25); defaults are the thesis's 30 m and 3 mrad.
    The Jacobian is H1/H2 of eqs. 5.23-5.24 at the position relative to the
    radar, padded with zero columns to the state size.
    """

    sigma_range: float = 30.0
    sigma_azimuth: float = 3e-3
    origin: tuple[float, float] = (0.0, 0.0)
    dim: ClassVar[int] = 2

    def __post_init__(self) -> None:
        check_positive("PolarMeasurement.sigma_range", self.sigma_range, error=FilterError)
        check_positive("PolarMeasurement.sigma_azimuth", self.sigma_azimuth, error=FilterError)
        origin = check_array("PolarMeasurement.origin", self.origin, (2,), error=FilterError)
        check_finite("PolarMeasurement.origin", origin, error=FilterError)
        object.__setattr__(self, "origin", (float(origin[0]), float(origin[1])))

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> PolarMeasurement:
        """The measurement model of a scenario's polar sensor, at its position."""
        if sensor.kind != "polar":
            raise FilterError(f"PolarMeasurement.from_sensor: sensor {sensor.name!r} is a {sensor.kind} sensor; "
                              f"use measurement_model(sensor)")
        return cls(sensor.sigma_range_m, sensor.sigma_azimuth_rad, sensor.position)

    @cached_property
    def _shift(self) -> np.ndarray | None:
        """The origin as an array (2,), or None at (0, 0), where no shift is computed."""
        return None if self.origin == (0.0, 0.0) else np.array(self.origin)

    @cached_property
    def R(self) -> np.ndarray:
        return np.diag([self.sigma_range**2, self.sigma_azimuth**2])

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """h(x) (..., 2) with azimuth in [0, 2 pi), and H (..., 2, n) at x.

        H is a transposed view of a contiguous H^T (..., n, 2), the operand
        of P H^T, so that product runs on contiguous arrays.
        """
        p = x[..., 0:3:2]  # (px, py), relative to the radar
        if self._shift is not None:
            p = p - self._shift
        r, azimuth = cart_to_polar(p[..., 0], p[..., 1])
        z = np.empty((*x.shape[:-1], 2))
        z[..., 0] = r
        z[..., 1] = azimuth
        Ht = np.zeros((*x.shape[:-1], x.shape[-1], 2))
        Ht[..., 0:3:2, 0] = p / r[..., None]  # d range / d(px, py) = (px, py) / r
        Ht[..., 0:3:2, 1] = p[..., ::-1] * _AZIMUTH_SIGN / (r * r)[..., None]  # d azimuth: (py, -px) / r^2
        return z, Ht.swapaxes(-1, -2)

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        """(range difference m, azimuth difference rad wrapped to [-pi, pi))."""
        nu = z - z_pred
        nu[..., 1] = wrap_angle(nu[..., 1])
        return nu

    def position(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cartesian positions (..., 2) in the scenario frame (eqs. 5.26-5.27, shifted by the origin) and
        their covariances (..., 2, 2) (eqs. 5.44-5.46) of measurements z (..., 2): `polar_to_cart_at` and
        `converted_covariance` in one compiled loop (`_positions`, their arithmetic; the trackers convert a
        few contacts at a time, where numpy's per-call overhead was most of the cost)."""
        z = np.asarray(z, dtype=float)
        xy, cov = _positions(np.ascontiguousarray(z.reshape(-1, 2)), *self.origin, self.sigma_range**2,
                             self.sigma_azimuth**2)
        return xy.reshape(z.shape), cov.reshape(*z.shape, 2)

    def cartesian(self, z: np.ndarray) -> np.ndarray:
        """Cartesian positions (..., 2) in the scenario frame (`_cartesian`)."""
        z = np.asarray(z, dtype=float)
        return _cartesian(np.ascontiguousarray(z.reshape(-1, 2)), *self.origin).reshape(z.shape)

    def spread(self, z: np.ndarray, S: np.ndarray) -> np.ndarray:
        """S_rr + r^2 S_aa (m^2): range variance plus the cross-range variance at range r."""
        return S[..., 0, 0] + z[..., 0] ** 2 * S[..., 1, 1]

    def area_jacobian(self, z: np.ndarray) -> np.ndarray:
        """The range r (m): an area element is r dr dtheta."""
        return z[..., 0]

    def validate(self, name: str, z: np.ndarray) -> None:
        """Finite values and positive ranges."""
        if np.isfinite(z).all() and (z[..., 0] > 0).all():
            return
        check_finite(name, z, error=FilterError)
        if (z[..., 0] <= 0).any():
            where = tuple(int(i) for i in np.argwhere(z[..., 0] <= 0)[0])
            raise FilterError(f"{name}: range must be > 0, got {z[..., 0][where]} at index {where}")


@dataclass(frozen=True)
class PositionMeasurement:
    """A linear Cartesian position fix z = (x, y) = H X + e with e ~ N(0, R).

    ``covariance`` is R (2, 2) in m^2, given as nested sequences; it must be
    symmetric positive definite.
    """

    covariance: tuple[tuple[float, float], tuple[float, float]]
    dim: ClassVar[int] = 2

    def __post_init__(self) -> None:
        R = np.asarray(self.covariance, dtype=float)
        if R.shape != (2, 2):
            raise FilterError(f"PositionMeasurement.covariance: expected shape (2, 2), got {R.shape}")
        check_covariance("PositionMeasurement.covariance", R, error=FilterError)
        object.__setattr__(self, "covariance", tuple(map(tuple, R.tolist())))

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> PositionMeasurement:
        """The measurement model of a scenario's position sensor: R = sigma_position_m^2 I."""
        if sensor.kind != "position":
            raise FilterError(f"PositionMeasurement.from_sensor: sensor {sensor.name!r} is a {sensor.kind} sensor; "
                              f"use measurement_model(sensor)")
        var = sensor.sigma_position_m**2
        return cls(((var, 0.0), (0.0, var)))

    @cached_property
    def R(self) -> np.ndarray:
        return np.array(self.covariance)

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (..., 2) and the constant H (..., 2, n) selecting x and y."""
        H = np.zeros((*x.shape[:-1], 2, x.shape[-1]))
        H[..., 0, 0] = 1.0
        H[..., 1, 2] = 1.0
        return x[..., ::2][..., :2], H

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        return z - z_pred

    def position(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The fixes themselves and R for each."""
        return z, np.broadcast_to(self.R, (*z.shape[:-1], 2, 2))

    def cartesian(self, z: np.ndarray) -> np.ndarray:
        """The fixes themselves."""
        return z

    def spread(self, z: np.ndarray, S: np.ndarray) -> np.ndarray:
        """trace S (m^2)."""
        return S[..., 0, 0] + S[..., 1, 1]

    def area_jacobian(self, z: np.ndarray) -> np.ndarray:
        """1: the measurement space is the plane."""
        return np.ones(z.shape[:-1])

    def validate(self, name: str, z: np.ndarray) -> None:
        check_finite(name, z, error=FilterError)


def measurement_model(sensor: Sensor) -> PolarMeasurement | PositionMeasurement:
    """The measurement model of a scenario's sensor, by its kind (polar or position), at its position."""
    if sensor.kind == "position":
        return PositionMeasurement.from_sensor(sensor)
    return PolarMeasurement.from_sensor(sensor)
