"""Motion models of the IMM: constant velocity (CV) and coordinated turn (CT), Vargas Avila (2015), eqs. 5.7-5.18.

Every method works on a batch: states of shape (..., n) and sampling
intervals ``dt`` (s) broadcastable to the batch shape (...). The interval is
per track and variable (2, 4, 6 or 8 s: the time since the track's last
update).

State vectors: CV [x, vx, y, vy]; CT [x, vx, y, vy, omega],
metres, m/s and rad/s, omega positive counter-clockwise in the x-east/y-north
plane (the sign of the thesis's CT transition; a pilot's right turn is
omega < 0). Each model's first four components are the CV state, so a
two-point CV estimate extends to any model (`from_cv`).

Process noise is ``Q = Gamma diag(sigma^2) Gamma^T`` with the thesis's noise
gains (``noise_kind = "discrete"``: an acceleration held constant over each
interval, whose velocity variance grows as T^2; right for one fixed scan
period), or the continuous white-noise acceleration of spectral density
sigma^2 (``noise_kind = "continuous"``, m^2/s^3: velocity variance sigma^2 T,
consistent for any interval, as asynchronous reports need; Bar-Shalom, Li and
Kirubarajan (2001), Sec. 6.2.2). Every model writes it as
``Q(T) = T Q1 + T^2 Q2 + T^3 Q3 + T^4 Q4`` with constant matrices
(``noise_basis``), which is how it is evaluated for a batch of intervals (and
how the IMM evaluates all its models' noise in one product).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar, Literal, Protocol

import numba
import numpy as np

from nnda.errors import FilterError
from nnda.validation import check_nonnegative, check_positive

#: position and velocity indices of the CV part of every state, [x, vx, y, vy]
POS = np.array([0, 2])
VEL = np.array([1, 3])


class MotionModel(Protocol):
    """What the filters need from a motion model (batched over leading axes).

    ``position`` (2,) gives the indices of x and y (m) in the state: [0, 2]
    for the CV layout [x, vx, y, vy, ...], [0, 1] for a heading state [x, y,
    v, alpha]; a Cartesian position fix is H x with H picking them.
    ``angles`` are the indices of entries that are angles (rad: compared and
    averaged on the circle when components merge), () for the CV layout.
    """

    dim: int
    position: np.ndarray
    angles: tuple[int, ...]

    @property
    def noise_basis(self) -> np.ndarray:
        """(4, n, n) constant matrices Q1, Q2, Q3, Q4 of Q(T) = T Q1 + T^2 Q2 + T^3 Q3 + T^4 Q4."""
        ...

    def transition(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Predicted states f(x) (..., n) and the transition Jacobian (..., n, n).

        ``dt`` (s) is a float array broadcastable to ``x.shape[:-1]``. The
        Jacobian is written into ``out`` (..., n, n) when given (for example
        a model's slot of the IMM's padded stack), else into a new array.
        """
        ...

    def noise(self, dt: np.ndarray) -> np.ndarray:
        """Process-noise covariance Q (..., n, n) for intervals dt (...)."""
        ...

    def from_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """This model's state (..., n) and covariance (..., n, n) from a CV estimate."""
        ...

    def to_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The CV estimate [x, vx, y, vy] (..., 4), (..., 4, 4) of this model's states (what trackers report)."""
        ...

    def newborn(self, xy: np.ndarray, cov: np.ndarray, speed_sigma: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Components of a target first seen at fixes ``xy`` (k, 2) m with covariances ``cov`` (k, 2, 2),
        its velocity unknown (0 +/- ``speed_sigma`` m/s per axis): means (c, n), covariances (c, n, n) and
        the fix each comes from (c,) (a model may spread one fix over several components)."""
        ...


def standing_newborn(model: MotionModel, xy: np.ndarray, cov: np.ndarray, speed_sigma: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`MotionModel.newborn` for a model with a CV part: one component per fix, CV [x, 0, y, 0] with the
    fix's covariance and ``speed_sigma``^2 on each velocity, mapped by ``model.from_cv``."""
    k = len(xy)
    x = np.zeros((k, 4))
    x[:, POS] = xy
    P = np.zeros((k, 4, 4))
    P[:, POS[:, None], POS] = cov
    P[:, VEL, VEL] = speed_sigma**2
    x, P = model.from_cv(x, P)
    return x, P, np.arange(k)


#: how the process noise grows with the interval (module docstring)
NOISE_KINDS = ("discrete", "continuous")
#: the coordinated turn's transition: the thesis's second-order form, or the exact turn
TURN_FORMS = ("second-order", "exact")

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


def process_noise(dt: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Q(T) = T basis[0] + T^2 basis[1] + T^3 basis[2] + T^4 basis[3] for T (s) of shape (...).

    ``basis`` (4, *M) holds the constant matrices (``MotionModel.noise_basis``,
    or several models' stacked, M = (r, n, n)); returns (..., *M).
    """
    T = np.asarray(dt, dtype=float)
    T2 = T * T
    flat = basis.reshape(4, -1)
    # sums of broadcast products, not (..., 4) @ (4, M): that tall product is multithreaded by BLAS,
    # which on a busy machine made the IMM's predict twice as slow at 10,000 tracks
    Q = T[..., None] * flat[0]
    Q += T2[..., None] * flat[1]
    Q += (T2 * T)[..., None] * flat[2]
    Q += (T2 * T2)[..., None] * flat[3]
    return Q.reshape(*T.shape, *basis.shape[1:])


def _wna_basis(dim: int, sigma_q: float, velocity_power: float, noise: str = "discrete") -> np.ndarray:
    """Noise basis (4, dim, dim) of white-noise acceleration on both axes.

    Discrete: per axis the block is sigma_q^2 [[T^4/4, T^3/2], [T^3/2, c T^2]]
    with c = 1 from Gamma diag Gamma^T and c = 1/2 in the CT matrix as
    printed. Continuous: sigma_q^2 [[T^3/3, T^2/2], [T^2/2, T]].
    """
    basis = np.zeros((4, dim, dim))
    q2 = sigma_q**2
    for p, v in zip(POS, VEL):
        if noise == "continuous":
            basis[2, p, p] = q2 / 3.0  # T^3
            basis[1, p, v] = basis[1, v, p] = q2 / 2.0  # T^2
            basis[0, v, v] = q2  # T
        else:
            basis[3, p, p] = q2 / 4.0  # T^4
            basis[2, p, v] = basis[2, v, p] = q2 / 2.0  # T^3
            basis[1, v, v] = q2 * velocity_power  # T^2
    return basis


def _check_noise(model: str, noise: str) -> None:
    if noise not in NOISE_KINDS:
        raise FilterError(f"{model}.noise_kind: 'discrete' or 'continuous', got {noise!r}")


@_jit
def exact_turn(w, T, vx, vy, F):
    """The coordinated turn at the constant rate w (rad/s, counter-clockwise) over T (s), exactly, into F
    (n, n): its CV block (4, 4), with sin(wT) / w and (1 - cos(wT)) / w on the positions, and its column 4
    the derivative of f(x) in w at the velocity (vx, vy) (Bar-Shalom, Li and Kirubarajan (2001), Sec.
    11.7); as series in wT below 1e-3 (error of order (wT)^4). Unlike the second-order form it keeps the
    speed over any interval."""
    wT = w * T
    if abs(wT) < 1e-3:
        a = T * (1.0 - wT * wT / 6.0)  # sin(wT) / w
        b = 0.5 * wT * T * (1.0 - wT * wT / 12.0)  # (1 - cos(wT)) / w
        da = -w * T * T * T / 3.0  # d/dw of sin(wT) / w
        db = 0.5 * T * T * (1.0 - wT * wT / 4.0)  # d/dw of (1 - cos(wT)) / w
        sn, cs = wT * (1.0 - wT * wT / 6.0), 1.0 - 0.5 * wT * wT
    else:
        sn, cs = math.sin(wT), math.cos(wT)
        a, b = sn / w, (1.0 - cs) / w
        da, db = (T * cs - a) / w, (T * sn - b) / w
    F[0, 1], F[0, 3] = a, -b
    F[1, 1], F[1, 3] = cs, -sn
    F[2, 1], F[2, 3] = b, a
    F[3, 1], F[3, 3] = sn, cs
    F[0, 4] = vx * da - vy * db
    F[1, 4] = -T * (sn * vx + cs * vy)
    F[2, 4] = vx * db + vy * da
    F[3, 4] = T * (cs * vx - sn * vy)


@_jit
def _exact_turns(w, T, vx, vy, F):
    """`exact_turn` for a batch: rates w, intervals T, velocities vx, vy (K,) into F (K, 5, 5) (identity in)."""
    for k in range(w.size):
        exact_turn(w[k], T[k], vx[k], vy[k], F[k])


@dataclass(frozen=True)
class ConstantVelocity:
    """Nearly constant velocity with white-noise acceleration.

    Transition F (eq. 5.8), noise gain Gamma (eq. 5.9) and
    Q = sigma_q^2 Gamma Gamma^T (eq. 5.10). ``sigma_q`` (m/s^2) defaults to the
    thesis's 0.7 a_max = 3.5. With ``noise_kind = "continuous"`` the noise is the
    continuous white-noise acceleration of spectral density sigma_q^2
    (m^2/s^3; module docstring).
    """

    sigma_q: float = 3.5
    noise_kind: str = "discrete"
    dim: ClassVar[int] = 4
    position: ClassVar[np.ndarray] = POS
    angles: ClassVar[tuple[int, ...]] = ()

    def __post_init__(self) -> None:
        check_nonnegative("ConstantVelocity.sigma_q", self.sigma_q, error=FilterError)
        _check_noise("ConstantVelocity", self.noise_kind)

    @cached_property
    def noise_basis(self) -> np.ndarray:
        """Q1, Q2, Q3, Q4 (4, 4, 4) of eq. 5.10 (or of the continuous noise)."""
        return _wna_basis(4, self.sigma_q, 1.0, self.noise_kind)

    def transition(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """f(x) = F x and F (eq. 5.8) for states (..., 4) and intervals dt (s); F goes into ``out`` if given."""
        F = np.empty((*x.shape[:-1], 4, 4)) if out is None else out
        F[...] = _EYE4
        F[..., 0, 1] = dt
        F[..., 2, 3] = dt
        return (F @ x[..., None])[..., 0], F

    def noise(self, dt: np.ndarray) -> np.ndarray:
        """Q(T) of eq. 5.10, shape (..., 4, 4)."""
        return process_noise(dt, self.noise_basis)

    def from_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The CV estimate itself (eq. 5.30)."""
        return x, P

    def to_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The state itself."""
        return x, P

    def newborn(self, xy: np.ndarray, cov: np.ndarray, speed_sigma: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One standing component per fix (`standing_newborn`)."""
        return standing_newborn(self, xy, cov, speed_sigma)


@dataclass(frozen=True)
class CoordinatedTurn:
    """Coordinated turn with an estimated turn rate.

    The transition is the thesis's second-order Taylor form f(X) (eq. 5.17),
    implemented as written (not the exact sin/cos turn), with the EKF Jacobian
    of eq. 5.18. The turn rate used to propagate is limited to
    [-omega_max, omega_max] (the thesis's omega_max = 5 deg/s); the propagated state
    carries the limited value.

    Process noise Q = Gamma diag(sigma_q^2, sigma_q^2, sigma_omega^2) Gamma^T
    with Gamma of eq. 5.14 (T^2 on the velocity and turn-rate diagonals, as
    the thesis's derivation gives). ``noise_variant="printed"`` uses the matrix as
    printed (eq. 5.15, T^2/2 on those diagonals); note that the printed
    per-axis block [[T^4/4, T^3/2], [T^3/2, T^2/2]] sigma_q^2 has a negative
    determinant, so it is not a covariance on its own.

    ``omega_var0`` (rad/s)^2 is the initial turn-rate variance P_omega of
    eq. 5.56; the initial turn rate is 0 (eq. 5.31). With ``noise_kind =
    "continuous"`` the noise is continuous white noise of spectral densities
    sigma_q^2 (m^2/s^3) and sigma_omega^2 ((rad/s)^2/s): the turn rate's
    variance grows as sigma_omega^2 T (module docstring).
    """

    sigma_q: float = 5.0
    sigma_omega: float = 0.044
    omega_max: float = math.radians(5.0)
    omega_var0: float = 0.0076
    noise_variant: Literal["derived", "printed"] = "derived"
    noise_kind: str = "discrete"
    form: str = "second-order"
    dim: ClassVar[int] = 5
    position: ClassVar[np.ndarray] = POS
    angles: ClassVar[tuple[int, ...]] = ()

    def __post_init__(self) -> None:
        check_nonnegative("CoordinatedTurn.sigma_q", self.sigma_q, error=FilterError)
        check_nonnegative("CoordinatedTurn.sigma_omega", self.sigma_omega, error=FilterError)
        check_positive("CoordinatedTurn.omega_max", self.omega_max, error=FilterError)
        check_positive("CoordinatedTurn.omega_var0", self.omega_var0, error=FilterError)
        if self.noise_variant not in ("derived", "printed"):
            raise FilterError(f"CoordinatedTurn.noise_variant: 'derived' or 'printed', got {self.noise_variant!r}")
        _check_noise("CoordinatedTurn", self.noise_kind)
        if self.form not in TURN_FORMS:
            raise FilterError(f"CoordinatedTurn.form: 'second-order' or 'exact', got {self.form!r}")

    @cached_property
    def noise_basis(self) -> np.ndarray:
        """Q1, Q2, Q3, Q4 (4, 5, 5) of eqs. 5.14-5.15 (variant per ``noise_variant``), or of the continuous
        noise."""
        c = 1.0 if self.noise_variant == "derived" else 0.5
        basis = _wna_basis(5, self.sigma_q, c, self.noise_kind)
        if self.noise_kind == "continuous":
            basis[0, 4, 4] = self.sigma_omega**2
        else:
            basis[1, 4, 4] = c * self.sigma_omega**2
        return basis

    def transition(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """f(X) of eq. 5.17 and its Jacobian (eq. 5.18) for states (..., 5), dt in s (``form =
        "second-order"``), or the exact turn's (``form = "exact"``, `exact_turn`).

        With w the limited turn rate, f(X) = F(w) X (eq. 5.13) and the Jacobian
        is F(w) with its last column replaced by df/dw; it goes into ``out`` if given.
        """
        if self.form == "exact":
            return self._exact(x, dt, out)
        T = dt
        vx, vy = x[..., 1], x[..., 3]
        w = np.minimum(np.maximum(x[..., 4], -self.omega_max), self.omega_max)
        half_T2 = 0.5 * T * T
        wT = w * T
        w_half_T2 = w * half_T2
        c = 1.0 - 0.5 * wT * wT
        F = np.empty((*x.shape[:-1], 5, 5)) if out is None else out
        F[...] = _EYE5
        F[..., 0, 1] = T
        F[..., 0, 3] = -w_half_T2
        F[..., 1, 1] = c
        F[..., 1, 3] = -wT
        F[..., 2, 1] = w_half_T2
        F[..., 2, 3] = T
        F[..., 3, 1] = wT
        F[..., 3, 3] = c
        fx = (F @ x[..., None])[..., 0]
        fx[..., 4] = w
        wT2 = wT * T
        F[..., 0, 4] = -vy * half_T2
        F[..., 1, 4] = -vy * T - vx * wT2
        F[..., 2, 4] = vx * half_T2
        F[..., 3, 4] = vx * T - vy * wT2
        return fx, F

    def _exact(self, x: np.ndarray, dt: np.ndarray, out: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The exact turn (`exact_turn`) at the limited rate w over T: f(X) and its Jacobian for states (..., 5)
        and dt (s), in one compiled call for the batch."""
        shape = x.shape[:-1]
        w = np.minimum(np.maximum(x[..., 4], -self.omega_max), self.omega_max)
        F = np.empty((*shape, 5, 5)) if out is None else out
        F[...] = _EYE5
        flat = np.ascontiguousarray(F.reshape(-1, 5, 5))
        _exact_turns(np.ravel(w).astype(float), np.ravel(np.broadcast_to(np.asarray(dt, float), shape)).copy(),
                     np.ravel(x[..., 1]).astype(float), np.ravel(x[..., 3]).astype(float), flat)
        F[...] = flat.reshape(F.shape)
        fx = np.empty_like(x)
        fx[..., :4] = (F[..., :4, :4] @ x[..., :4, None])[..., 0]
        fx[..., 4] = w
        return fx, F

    def noise(self, dt: np.ndarray) -> np.ndarray:
        """Q(T) of eq. 5.14-5.15 (variant per ``noise_variant``), shape (..., 5, 5)."""
        return process_noise(dt, self.noise_basis)

    def from_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Append omega = 0 with variance ``omega_var0`` (eqs. 5.31 and 5.56)."""
        x5 = np.zeros((*x.shape[:-1], 5))
        x5[..., :4] = x
        P5 = np.zeros((*P.shape[:-2], 5, 5))
        P5[..., :4, :4] = P
        P5[..., 4, 4] = self.omega_var0
        return x5, P5

    def to_cv(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The CV part: the first four entries."""
        return x[..., :4], P[..., :4, :4]

    def newborn(self, xy: np.ndarray, cov: np.ndarray, speed_sigma: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One standing component per fix (`standing_newborn`)."""
        return standing_newborn(self, xy, cov, speed_sigma)


_EYE4 = np.eye(4)
_EYE5 = np.eye(5)
