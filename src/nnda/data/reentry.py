"""Ballistic re-entry truth and radar data of Pavlov & Bruno (2003).

A flat-Earth 2-D model: state s = [x, vx, y, vy] (m, m/s), x downrange and
y altitude, the radar at the origin measuring range r (m) and elevation eps
(rad, above the horizontal: x = r cos eps, y = r sin eps; not the azimuth
convention of the surveillance radar). R runs of K steps at once:

    cfg = ReentryConfig(sigma_r=200.0)                 # the paper's Monte Carlo setting, 55 steps
    data = simulate(cfg, runs=100, seed=0)             # data.truth (R, K+1, 4), data.z (R, K, 2)
    data.cov                                           # converted-measurement covariances R_k (R, K, 2, 2)
    g = transition_mean(s, cfg)                        # g(s) = Phi s + G f(s) + G [0, -g], s (..., 4)
    s_free, impact = noise_free_trajectory(cfg)        # (impact, 4) from m0 without noise; first step below ground

Dynamics (eqs. 1-5): s_k+1 = Phi s_k + G (f(s_k) + [0, -g]) + w_k with the
drag acceleration f(s) = -0.5 (g / beta) rho(y) |v| v (m/s^2), the two-layer
air density rho (kg/m^3) and w_k ~ N(0, Q), Q = sigma_w^2 blkdiag(Theta,
Theta). Measurements (eq. 6): z_k = [r cos eps, r sin eps] = H s_k + v_k with
the converted covariance R_k of eqs. 7-10 evaluated at the measured (r, eps).
Two data modes (the paper allows either): ``"polar"`` adds noise to r and eps and converts;
``"gaussian"`` draws v_k ~ N(0, R_k(true r, eps)). In both, the R_k a filter
gets is the one of the measurement's own (r, eps).

A run stops at ground impact: ``steps`` caps the length, and the data of a
batch end at the last step every run is still at or above y = 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from nnda.errors import ConfigError

#: standard gravity of the paper (m/s^2)
GRAVITY = 9.8
#: altitude (m) where the two density layers meet
LAYER_ALTITUDE = 9144.0
#: rho = c1 exp(-c2 y) below (c1 kg/m^3, c2 1/m) and at or above LAYER_ALTITUDE
LOW_LAYER = (1.227, 1.093e-4)
HIGH_LAYER = (1.754, 1.49e-4)
#: the measurement matrix of the converted measurement: z = H s + v
H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])


class ReentryConfig(BaseModel):
    """The re-entry model and radar (defaults: the paper's Monte Carlo setting).

    ``dt`` scan period (s); ``sigma_w`` process-noise intensity (m s^-3/2,
    "q = 1"); ``beta`` ballistic coefficient (kg m^-1 s^-2); ``drag`` False
    switches drag off (a linear-Gaussian model, checkable against a Kalman filter); ``speed`` (m/s),
    ``heading_deg`` (degrees, counter-clockwise from +x: 190 is 10 deg below
    the horizontal towards the radar), ``x0``, ``y0`` (m) the initial mean;
    ``sd0_position`` (m) and ``sd0_velocity`` (m/s) its standard deviations;
    ``sigma_r`` (m) and ``sigma_eps`` (rad) the radar noise; ``mode`` the data
    mode; ``steps`` the most steps of a run.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    dt: float = Field(2.0, gt=0)
    sigma_w: float = Field(1.0, ge=0)
    beta: float = Field(40000.0, gt=0)
    drag: bool = True
    speed: float = Field(2290.0, ge=0)
    heading_deg: float = 190.0
    x0: float = 232000.0
    y0: float = Field(88000.0, ge=0)
    sd0_position: float = Field(100.0, gt=0)
    sd0_velocity: float = Field(20.0, gt=0)
    sigma_r: float = Field(200.0, gt=0)
    sigma_eps: float = Field(0.017, gt=0)
    mode: Literal["polar", "gaussian"] = "polar"
    steps: int = Field(55, ge=1)


def air_density(y: np.ndarray | float) -> np.ndarray:
    """Two-layer air density rho(y) (kg/m^3) at altitudes y (m), any shape."""
    y = np.asarray(y)
    low = y < LAYER_ALTITUDE
    c1 = np.where(low, LOW_LAYER[0], HIGH_LAYER[0])
    c2 = np.where(low, LOW_LAYER[1], HIGH_LAYER[1])
    return c1 * np.exp(-c2 * y)


def transition_matrices(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Phi (4, 4) and G (4, 2) of eq. 3 for the scan period dt (s)."""
    Phi = np.array([[1.0, dt, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, dt], [0, 0, 0, 1.0]])
    G = np.array([[dt**2 / 2, 0], [dt, 0], [0, dt**2 / 2], [0, dt]])
    return Phi, G


def white_noise_acceleration(dt: float, q: float) -> np.ndarray:
    """Q (4, 4) of nearly-constant velocity in [x, vx, y, vy]: q blkdiag(Theta, Theta), Theta = [[dt^3/3,
    dt^2/2], [dt^2/2, dt]] (q the acceleration noise's power spectral density)."""
    theta = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    Q = np.zeros((4, 4))
    Q[:2, :2] = Q[2:, 2:] = q * theta
    return Q


def process_noise(cfg: ReentryConfig) -> np.ndarray:
    """Q (4, 4) of eq. 4: sigma_w^2 blkdiag(Theta, Theta)."""
    return white_noise_acceleration(cfg.dt, cfg.sigma_w**2)


def initial_distribution(cfg: ReentryConfig) -> tuple[np.ndarray, np.ndarray]:
    """Mean m0 (4,) and covariance Sigma0 (4, 4) of the initial state (eqs. 11-12)."""
    h = np.deg2rad(cfg.heading_deg)
    m0 = np.array([cfg.x0, cfg.speed * np.cos(h), cfg.y0, cfg.speed * np.sin(h)])
    sd = np.array([cfg.sd0_position, cfg.sd0_velocity, cfg.sd0_position, cfg.sd0_velocity])
    return m0, np.diag(sd**2)


def drag_acceleration(s: np.ndarray, cfg: ReentryConfig) -> np.ndarray:
    """f(s) = -0.5 (g / beta) rho(y) |v| v (..., 2) in m/s^2 for states s (..., 4) (eq. 5); zero without drag."""
    v = s[..., 1::2]
    if not cfg.drag:
        return np.zeros_like(v)
    speed = np.sqrt(s[..., 1] ** 2 + s[..., 3] ** 2)
    k = (-0.5 * GRAVITY / cfg.beta) * air_density(s[..., 2]) * speed
    return k[..., None].astype(s.dtype, copy=False) * v


def transition_mean(s: np.ndarray, cfg: ReentryConfig) -> np.ndarray:
    """g(s) = Phi s + G (f(s) + [0, -g]) (..., 4) for states s (..., 4) (eq. 17), in the dtype of s."""
    dt = cfg.dt
    a = drag_acceleration(s, cfg)
    a[..., 1] -= GRAVITY
    out = np.empty_like(s)
    out[..., 0] = s[..., 0] + dt * s[..., 1] + (dt * dt / 2) * a[..., 0]
    out[..., 1] = s[..., 1] + dt * a[..., 0]
    out[..., 2] = s[..., 2] + dt * s[..., 3] + (dt * dt / 2) * a[..., 1]
    out[..., 3] = s[..., 3] + dt * a[..., 1]
    return out


def transition_jacobian(s: np.ndarray, cfg: ReentryConfig) -> np.ndarray:
    """d g / d s (..., 4, 4) at states s (..., 4): Phi + G df/ds, df/ds the drag's Jacobian."""
    Phi, G = transition_matrices(cfg.dt)
    J = np.zeros((*s.shape[:-1], 2, 4))
    if cfg.drag:
        v = s[..., 1::2]
        speed = np.sqrt((v**2).sum(axis=-1))
        y = s[..., 2]
        c2 = np.where(y < LAYER_ALTITUDE, LOW_LAYER[1], HIGH_LAYER[1])
        k = (-0.5 * GRAVITY / cfg.beta) * air_density(y)
        # d(|v| v)/dv = |v| I + v v^T / |v|;  d rho / dy = -c2 rho
        dv = speed[..., None, None] * np.eye(2) + v[..., :, None] * v[..., None, :] / speed[..., None, None]
        J[..., :, [1, 3]] = k[..., None, None] * dv
        J[..., :, 2] = (-c2 * k * speed)[..., None] * v
    return Phi + G @ J


def converted_covariance(r: np.ndarray, eps: np.ndarray, sigma_r: float, sigma_eps: float) -> np.ndarray:
    """R_k (..., 2, 2) (m^2) of the converted measurement at range r (m) and elevation eps (rad) (eqs. 7-10)."""
    c, s = np.cos(eps), np.sin(eps)
    cross = (r * sigma_eps) ** 2
    R = np.empty((*np.shape(r), 2, 2))
    R[..., 0, 0] = sigma_r**2 * c * c + cross * s * s
    R[..., 1, 1] = sigma_r**2 * s * s + cross * c * c
    R[..., 0, 1] = R[..., 1, 0] = (sigma_r**2 - cross) * s * c
    return R


def to_polar(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Range (m) and elevation (rad) of Cartesian points p (..., 2) = [x, y] seen from the origin."""
    return np.hypot(p[..., 0], p[..., 1]), np.arctan2(p[..., 1], p[..., 0])


def noise_free_trajectory(cfg: ReentryConfig, most_steps: int = 1000) -> tuple[np.ndarray, int]:
    """The trajectory from m0 without process noise, (impact, 4), and the first step whose altitude is < 0."""
    m0, _ = initial_distribution(cfg)
    states = [m0]
    for k in range(1, most_steps + 1):
        s = transition_mean(states[-1], cfg)
        if s[2] < 0:
            return np.array(states), k
        states.append(s)
    raise ConfigError(f"noise_free_trajectory: no ground impact within {most_steps} steps")


@dataclass(frozen=True)
class ReentryData:
    """R runs of K steps on shared settings.

    ``truth`` (R, K+1, 4) the states s_0..s_K; ``z`` (R, K, 2) the converted
    measurements of steps 1..K (m); ``polar`` (R, K, 2) their range (m) and
    elevation (rad); ``cov`` (R, K, 2, 2) the R_k a filter uses; ``impact``
    (R,) the step each run first went below ground (0: not within the steps
    simulated); ``config`` the settings.
    """

    truth: np.ndarray
    z: np.ndarray
    polar: np.ndarray
    cov: np.ndarray
    impact: np.ndarray
    config: ReentryConfig

    @property
    def steps(self) -> int:
        """K, the steps with a measurement."""
        return self.z.shape[1]

    def take(self, index: slice) -> ReentryData:
        """The runs ``index`` (a slice of the run axis), same settings."""
        return ReentryData(self.truth[index], self.z[index], self.polar[index], self.cov[index],
                           self.impact[index], self.config)


#: bytes per run and step that `simulate` needs at its peak: the arrays it returns (truth, z, polar, cov: 97 B)
#: and its temporaries (the noise, the true range and elevation, the Cholesky factors of the "gaussian" mode)
SIMULATE_BYTES = 208


def simulate_bytes(cfg: ReentryConfig, runs: int) -> int:
    """Bytes `simulate` needs for ``runs`` runs of ``cfg`` (all ``cfg.steps`` steps, before the cut at impact):
    arithmetic on the config, for a caller to refuse a size before anything is allocated."""
    return runs * cfg.steps * SIMULATE_BYTES


def simulate(cfg: ReentryConfig, runs: int, seed: int | np.random.Generator) -> ReentryData:
    """``runs`` trajectories and their measurements, cut at the earliest ground impact.

    Every draw comes from one Generator (``seed`` or a Generator): the same
    seed gives the same arrays. Raises ConfigError for runs < 1 or a run
    that is below ground at step 1.
    """
    if runs < 1:
        raise ConfigError(f"simulate: runs must be >= 1, got {runs}")
    rng = np.random.default_rng(seed)
    m0, P0 = initial_distribution(cfg)
    LQ = np.linalg.cholesky(process_noise(cfg)) if cfg.sigma_w > 0 else np.zeros((4, 4))
    K = cfg.steps
    truth = np.empty((runs, K + 1, 4))
    truth[:, 0] = m0 + rng.standard_normal((runs, 4)) * np.sqrt(np.diag(P0))
    for k in range(1, K + 1):
        truth[:, k] = transition_mean(truth[:, k - 1], cfg) + rng.standard_normal((runs, 4)) @ LQ.T
    below = truth[:, 1:, 2] < 0
    impact = np.where(below.any(axis=1), below.argmax(axis=1) + 1, 0)
    last = K if not below.any() else int(impact[impact > 0].min()) - 1
    if last < 1:
        raise ConfigError("simulate: a run is below ground at step 1; nothing to measure")
    truth = truth[:, :last + 1]
    r_true, e_true = to_polar(truth[:, 1:, ::2])
    noise = rng.standard_normal((runs, last, 2))
    if cfg.mode == "polar":
        r = r_true + cfg.sigma_r * noise[..., 0]
        e = e_true + cfg.sigma_eps * noise[..., 1]
        z = np.stack([r * np.cos(e), r * np.sin(e)], axis=-1)
    else:
        L = np.linalg.cholesky(converted_covariance(r_true, e_true, cfg.sigma_r, cfg.sigma_eps))
        z = truth[:, 1:, ::2] + (L @ noise[..., None])[..., 0]
        r, e = to_polar(z)
    cov = converted_covariance(r, e, cfg.sigma_r, cfg.sigma_eps)
    return ReentryData(truth, z, np.stack([r, e], axis=-1), cov, impact, cfg)
