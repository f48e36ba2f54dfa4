"""Pedestrian motion models of Frencl (2014), Ch. 5 and Sec. 6.2: a diagonal-noise CV, the modified NCSHT, the
HM-map model.

Batched like `nnda.filters.motion`: states (..., n), intervals ``dt`` (s)
broadcastable to (...); ``transition(x, dt) -> (f(x) (..., n), Jacobian
(..., n, n))`` and ``noise(dt) -> Q (..., n, n)``::

    cv = DiagonalCV()                    # [x, vx, y, vy], Q = diag(1/9, 0.18^2, 1/9, 0.18^2) at T = 1 s
    nc = ModifiedNCSHT()                 # [x, y, v, alpha]: alpha rad counter-clockwise from east
    hm = GroundVehicle(corridor_hm_map(), v0=1.5, rho=0.2)
    fx, F = hm.transition(x, 1.0)        # x (..., 4) -> (..., 4), (..., 4, 4)
    m_cv, P_cv = ncsht_to_cv(m, P)       # [x, y, v, alpha] estimate -> nnda's [x, vx, y, vy]

The thesis's process noise is a diagonal matrix per step of T = 1 s:
diag((1/3)^2, (1/3)^2, sigma_v^2, 0.18^2) for [x y vx vy] (sigma_v 0.18) and
[x y v alpha] (sigma_v = sqrt(1/12)). It gives no law in T; here Q(T) =
T^2 Q(1 s) (the ``noise_basis`` of `nnda.filters.motion.process_noise`),
exact at the thesis's T = 1 s.

The composite (eqs. 5.16-5.23) relaxes speed toward v0 with rho = T/tau_v
(a constant per step, as in the thesis) and heading toward the map's
alpha0(x, y) with xi(x, y) = T / tau_alpha(x, y) in [0, 1], both read at the
previous position: alpha = alpha' + xi wrap(alpha0 - alpha') (the shortest
arc: the thesis's (1 - xi) alpha' + xi alpha0 whenever |alpha0 - alpha'| <
pi). Where xi = 0 it is the modified NCSHT (no preferred direction, no
map): the speed is relaxed only where xi > 0 (our reading of that switch).
``jacobian="printed"`` is the thesis's J_F, whose heading row is
[-alpha' dxi/dx, -alpha' dxi/dy, 0, 1 - xi]; ``"complete"`` (default)
differentiates the transition as implemented: wrap(alpha0 - alpha') dxi/dx
in place of -alpha' dxi/dx (alpha0 is piecewise constant, nearest vertex).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from functools import cached_property
from typing import ClassVar, Literal

import numpy as np

from nnda.errors import FilterError
from nnda.filters.motion import ConstantVelocity, process_noise
from nnda.validation import check_array, check_finite, check_nonnegative, check_positive

#: the thesis's position noise std per step (m), heading noise std (rad), CV velocity noise std (m/s) and
#: the NCSHT speed noise std (m/s) (its Sec. 6.2, Q_k)
SIGMA_POSITION_M, SIGMA_HEADING_RAD, SIGMA_V_CV, SIGMA_V_NCSHT = 1.0 / 3.0, 0.18, 0.18, math.sqrt(1.0 / 12.0)
#: headings of the ring of newborn components a heading state puts on one fix (`ModifiedNCSHT.newborn`; ours:
#: with headings merged on the circle, 8, 12, 16 and 24 left 1-4% of walk-test3's true points two estimates;
#: 8 is the cheapest, 1.7 x faster than 24)
BIRTH_HEADINGS = 8


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _constant_basis(q_diag: tuple[float, ...]) -> np.ndarray:
    basis = np.zeros((4, len(q_diag), len(q_diag)))
    basis[1] = np.diag(q_diag)  # T^2
    return basis


@dataclass(frozen=True)
class DiagonalCV(ConstantVelocity):
    """CV on nnda's state [x, vx, y, vy] whose process noise is diagonal in position and velocity (Frencl
    (2014)'s CV, eq. 6.3, with its Q_k of Sec. 6.2), T^2-scaled; the transition is
    `nnda.filters.motion.ConstantVelocity`'s (its ``sigma_q`` is unused here)."""

    sigma_q: float = 0.0
    sigma_position_m: float = SIGMA_POSITION_M
    sigma_velocity_m_s: float = SIGMA_V_CV

    def __post_init__(self) -> None:
        super().__post_init__()
        check_nonnegative("DiagonalCV.sigma_position_m", self.sigma_position_m, error=FilterError)
        check_nonnegative("DiagonalCV.sigma_velocity_m_s", self.sigma_velocity_m_s, error=FilterError)

    @cached_property
    def noise_basis(self) -> np.ndarray:
        """Q(1 s) = diag(sigma_p^2, sigma_v^2, sigma_p^2, sigma_v^2) as the T^2 matrix, (4, 4, 4)."""
        p, v = self.sigma_position_m**2, self.sigma_velocity_m_s**2
        return _constant_basis((p, v, p, v))


@dataclass(frozen=True)
class ModifiedNCSHT:
    """The thesis's modified NCSHT (eqs. 5.11-5.12, 5.15): [x, y, v, alpha], speed and heading held."""

    sigma_position_m: float = SIGMA_POSITION_M
    sigma_speed_m_s: float = SIGMA_V_NCSHT
    sigma_heading_rad: float = SIGMA_HEADING_RAD
    dim: ClassVar[int] = 4
    position: ClassVar[np.ndarray] = np.array([0, 1])
    angles: ClassVar[tuple[int, ...]] = (3,)

    def __post_init__(self) -> None:
        for name in ("sigma_position_m", "sigma_speed_m_s", "sigma_heading_rad"):
            check_nonnegative(f"{type(self).__name__}.{name}", getattr(self, name), error=FilterError)

    @cached_property
    def noise_basis(self) -> np.ndarray:
        p = self.sigma_position_m**2
        return _constant_basis((p, p, self.sigma_speed_m_s**2, self.sigma_heading_rad**2))

    def noise(self, dt: np.ndarray) -> np.ndarray:
        return process_noise(dt, self.noise_basis)

    def _kinematics(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None):
        T = np.asarray(dt, dtype=float)
        v, a = x[..., 2], x[..., 3]
        c, s = np.cos(a), np.sin(a)
        fx = x.copy()
        fx[..., 0] = x[..., 0] + v * c * T
        fx[..., 1] = x[..., 1] + v * s * T
        F = np.empty((*x.shape[:-1], 4, 4)) if out is None else out
        F[...] = np.eye(4)
        F[..., 0, 2] = c * T
        F[..., 0, 3] = -v * s * T
        F[..., 1, 2] = s * T
        F[..., 1, 3] = v * c * T
        return fx, F

    def transition(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """f(x) = [x + v cos(alpha) T, y + v sin(alpha) T, v, alpha] and J_F (eq. 5.15)."""
        return self._kinematics(np.asarray(x, dtype=float), dt, out)

    def from_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """This state from a CV estimate [x, vx, y, vy] (`cv_to_ncsht`)."""
        return cv_to_ncsht(x, P)

    def to_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """nnda's CV estimate of this state (`ncsht_to_cv`)."""
        return ncsht_to_cv(x, P)

    def newborn(self, xy: np.ndarray, cov: np.ndarray, speed_sigma: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A ring of `BIRTH_HEADINGS` components per fix: the heading of a target whose velocity is 0 +/- s
        per axis is uniform, its speed Rayleigh (mean s sqrt(pi/2), std s sqrt(2 - pi/2)); component h has
        heading 2 pi h / H - pi, std half the ring's spacing, that speed's mean and std, the fix's position.
        Returns means (k H, 4), covariances (k H, 4, 4) and the fix of each (k H,), fix-major."""
        k, h = len(xy), BIRTH_HEADINGS
        of = np.repeat(np.arange(k), h)
        x = np.zeros((k * h, 4))
        x[:, :2] = xy[of]
        x[:, 2] = speed_sigma * math.sqrt(math.pi / 2.0)
        x[:, 3] = np.tile(2.0 * np.pi * np.arange(h) / h - np.pi, k)
        P = np.zeros((k * h, 4, 4))
        P[:, :2, :2] = cov[of]
        P[:, 2, 2] = speed_sigma**2 * (2.0 - math.pi / 2.0)
        P[:, 3, 3] = (np.pi / h) ** 2
        return x, P, of


@dataclass(frozen=True)
class HMMap:
    """A "hospitality for manoeuvres" map (the thesis's Sec. 5.1.4): xi and alpha0 at the vertices of a square grid.

    ``xi`` and ``alpha0`` (n_rows, n_cols): the value at the vertex (x, y) =
    (col cell_m, row cell_m), m, from the origin; row 0 is y = 0. xi is clipped
    to [0, 1] here and read bilinearly between vertices (so dxi/dx exists
    inside each cell); alpha0 (rad, counter-clockwise from east) is read at the
    nearest vertex. Positions off the grid read the nearest edge, with zero
    gradient.
    """

    xi: np.ndarray
    alpha0: np.ndarray
    cell_m: float = 1.0
    clipped: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        check_positive("HMMap.cell_m", self.cell_m, error=FilterError)
        xi = check_array("HMMap.xi", self.xi, (None, None), error=FilterError)
        a0 = check_array("HMMap.alpha0", self.alpha0, xi.shape, error=FilterError)
        if min(xi.shape) < 2:
            raise FilterError(f"HMMap.xi: a grid of at least 2 x 2 vertices is needed, got {xi.shape}")
        check_finite("HMMap.xi", xi, error=FilterError)
        check_finite("HMMap.alpha0", a0, error=FilterError)
        object.__setattr__(self, "clipped", int(((xi < 0) | (xi > 1)).sum()))
        object.__setattr__(self, "xi", np.clip(xi, 0.0, 1.0))
        object.__setattr__(self, "alpha0", a0.copy())

    def read(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(xi, dxi/dx, dxi/dy, alpha0) at positions (m), each of their broadcast shape."""
        n_rows, n_cols = self.xi.shape
        gx, gy = np.asarray(x, float) / self.cell_m, np.asarray(y, float) / self.cell_m
        inside_x, inside_y = (gx >= 0) & (gx <= n_cols - 1), (gy >= 0) & (gy <= n_rows - 1)
        gx, gy = np.clip(gx, 0.0, n_cols - 1), np.clip(gy, 0.0, n_rows - 1)
        i = np.minimum(np.floor(gx).astype(np.intp), n_cols - 2)
        j = np.minimum(np.floor(gy).astype(np.intp), n_rows - 2)
        fx, fy = gx - i, gy - j
        v00, v01 = self.xi[j, i], self.xi[j, i + 1]
        v10, v11 = self.xi[j + 1, i], self.xi[j + 1, i + 1]
        xi = (1 - fy) * ((1 - fx) * v00 + fx * v01) + fy * ((1 - fx) * v10 + fx * v11)
        dx = np.where(inside_x, ((1 - fy) * (v01 - v00) + fy * (v11 - v10)) / self.cell_m, 0.0)
        dy = np.where(inside_y, ((1 - fx) * (v10 - v00) + fx * (v11 - v01)) / self.cell_m, 0.0)
        a0 = self.alpha0[np.rint(gy).astype(np.intp), np.rint(gx).astype(np.intp)]
        return xi, dx, dy, a0


@dataclass(frozen=True)
class GroundVehicle(ModifiedNCSHT):
    """The thesis's composite model: modified NCSHT relaxing speed to ``v0`` (m/s) with ``rho`` and heading to
    the map's alpha0 with its xi (module docstring); ``jacobian`` "complete" or "printed"."""

    hm_map: HMMap = field(default=None)  # type: ignore[assignment]
    v0: float = 1.5
    rho: float = 0.2
    jacobian: Literal["complete", "printed"] = "complete"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.hm_map, HMMap):
            raise FilterError(f"GroundVehicle.hm_map: an HMMap is needed, got {type(self.hm_map).__name__}")
        check_nonnegative("GroundVehicle.v0", self.v0, error=FilterError)
        if not (0.0 <= self.rho <= 1.0):
            raise FilterError(f"GroundVehicle.rho: must lie in [0, 1] (rho = T / tau_v, tau_v >= T), got {self.rho}")
        if self.jacobian not in ("complete", "printed"):
            raise FilterError(f"GroundVehicle.jacobian: 'complete' or 'printed', got {self.jacobian!r}")

    def transition(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """f(x) of eqs. 5.16-5.23 (module docstring) and its Jacobian (``jacobian``)."""
        x = np.asarray(x, dtype=float)
        fx, F = self._kinematics(x, dt, out)
        xi, dxi_x, dxi_y, a0 = self.hm_map.read(x[..., 0], x[..., 1])
        mapped = xi > 0
        rho = np.where(mapped, self.rho, 0.0)
        v, a = x[..., 2], x[..., 3]
        gap = _wrap(a0 - a)
        fx[..., 2] = v + rho * (self.v0 - v)
        fx[..., 3] = a + xi * gap
        F[..., 2, 2] = 1.0 - rho
        F[..., 3, 3] = 1.0 - xi
        lever = -a if self.jacobian == "printed" else gap
        F[..., 3, 0] = lever * dxi_x
        F[..., 3, 1] = lever * dxi_y
        return fx, F


def ncsht_to_cv(m: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[x, y, v, alpha] estimates (..., 4), (..., 4, 4) -> nnda's [x, vx, y, vy] (first-order covariance)."""
    m, P = np.asarray(m, float), np.asarray(P, float)
    v, a = m[..., 2], m[..., 3]
    c, s = np.cos(a), np.sin(a)
    out = np.stack([m[..., 0], v * c, m[..., 1], v * s], axis=-1)
    J = np.zeros((*m.shape[:-1], 4, 4))
    J[..., 0, 0] = 1.0
    J[..., 1, 2], J[..., 1, 3] = c, -v * s
    J[..., 2, 1] = 1.0
    J[..., 3, 2], J[..., 3, 3] = s, v * c
    return out, J @ P @ np.swapaxes(J, -1, -2)


def cv_to_ncsht(m: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """nnda's [x, vx, y, vy] estimates -> [x, y, v, alpha] (first-order covariance; alpha 0 at zero speed)."""
    m, P = np.asarray(m, float), np.asarray(P, float)
    vx, vy = m[..., 1], m[..., 3]
    speed = np.hypot(vx, vy)
    safe = np.maximum(speed, 1e-9)
    out = np.stack([m[..., 0], m[..., 2], speed, np.arctan2(vy, vx)], axis=-1)
    J = np.zeros((*m.shape[:-1], 4, 4))
    J[..., 0, 0] = 1.0
    J[..., 1, 2] = 1.0
    J[..., 2, 1], J[..., 2, 3] = vx / safe, vy / safe
    J[..., 3, 1], J[..., 3, 3] = -vy / safe**2, vx / safe**2
    return out, J @ P @ np.swapaxes(J, -1, -2)


def corridor_hm_map(width_m: float = 100.0, height_m: float = 50.0, centre_y_m: float = 25.0,
                    scale_m2: float = 25.0) -> HMMap:
    """Test 4's map (eq. 6.9): xi = (y - 25)^2 / 25 clipped to [0, 1], alpha0 = 0 (east), 1 m vertices."""
    y = np.arange(round(height_m) + 1, dtype=float)[:, None]
    xi = np.broadcast_to((y - centre_y_m) ** 2 / scale_m2, (y.size, round(width_m) + 1))
    return HMMap(np.array(xi), np.zeros(xi.shape))


def plus_hm_map(size_m: float = 48.0, low_m: float = 18.0, high_m: float = 30.0) -> HMMap:
    """Fig. 5.1's "+" map (eq. 5.24): in each arm xi = (u - 24)^2 / 36 across it (clipped), 0 in the centre.

    alpha0 points out of the centre along each arm (north pi/2, east 0, west pi), as eq. 5.25's transitions
    from the centre; the thesis sets it from a component's region history, which a map of positions cannot
    hold, so the south arm (where our scene's walkers enter from the gate, never from the centre) has xi = 0.
    """
    n = round(size_m) + 1
    c = np.arange(n, dtype=float)
    X, Y = np.meshgrid(c, c)
    mid = (low_m + high_m) / 2
    half = (high_m - low_m) / 2
    in_ns = (X >= low_m) & (X <= high_m)
    in_ew = (Y >= low_m) & (Y <= high_m)
    centre = in_ns & in_ew
    north, east, west = in_ns & (Y > high_m), in_ew & (X > high_m), in_ew & (X < low_m)
    xi = np.zeros((n, n))
    xi[north] = ((X[north] - mid) ** 2 / half**2)
    xi[east | west] = ((Y[east | west] - mid) ** 2 / half**2)
    xi[centre] = 0.0
    alpha0 = np.zeros((n, n))
    alpha0[north], alpha0[west] = np.pi / 2, np.pi
    return HMMap(xi, alpha0)


def __getattr__(name: str) -> object:
    if name == "ThesisCV":
        warnings.warn("nnda.filters.ground_motion.ThesisCV is deprecated: use DiagonalCV", FutureWarning,
                      stacklevel=2)
        return DiagonalCV
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
