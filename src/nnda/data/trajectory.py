"""Noise-free target trajectories from a list of segments (Vargas Avila (2015), Appendix A).

State of the curvilinear model: position (x east, y north) in m, speed V in
m/s and heading psi in rad clockwise from north, so that

    dx/dt = V sin psi,  dy/dt = V cos psi,  dV/dt = a_t,  dpsi/dt = omega,

with omega = a_n / V or a fixed turn rate; omega > 0 is a right (clockwise)
turn. Straight, accelerating and constant-speed turning sections are
integrated in closed form; a section with both a_t and a turn (the thesis's
"mixed" section) goes through scipy's DOP853 at tight tolerances.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from nnda.data.scenario import Segment, Target

#: relative and absolute tolerances of the ODE solver for mixed sections (m, rad)
ODE_RTOL = 1e-11
ODE_ATOL = 1e-8


@dataclass(frozen=True)
class KinematicState:
    """Target states at a set of times; every array has shape (n,).

    ``t`` is target time (s from the target's start), ``heading`` rad clockwise
    from north, ``turn_rate`` rad/s (positive = right turn).
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    speed: np.ndarray
    heading: np.ndarray
    turn_rate: np.ndarray
    tangential_accel: np.ndarray

    @property
    def vx(self) -> np.ndarray:
        return self.speed * np.sin(self.heading)

    @property
    def vy(self) -> np.ndarray:
        return self.speed * np.cos(self.heading)


def turn_rate_rad_s(segment: Segment, speed: np.ndarray | float) -> np.ndarray:
    """Turn rate (rad/s, positive right) of a segment at the given speed(s)."""
    if segment.turn_rate_deg_s is not None:
        return np.full(np.shape(speed), math.radians(segment.turn_rate_deg_s))
    return (segment.normal_accel or 0.0) / np.asarray(speed, dtype=float)


def _closed_form(seg: Segment, start: tuple[float, float, float, float], tau: np.ndarray):
    """States at local times tau (s) for a section without a_t + turn together."""
    x0, y0, v0, psi0 = start
    a = seg.tangential_accel
    speed = v0 + a * tau
    omega = turn_rate_rad_s(seg, np.full_like(tau, v0))
    if a:  # straight, uniformly accelerated
        s = v0 * tau + 0.5 * a * tau**2
        return x0 + s * math.sin(psi0), y0 + s * math.cos(psi0), speed, np.full_like(tau, psi0), omega
    # Constant-speed arc: chord length V tau sinc(omega tau / 2) along the mean heading;
    # this form stays exact as omega -> 0 (np.sinc(u) = sin(pi u) / (pi u)).
    half = 0.5 * omega * tau
    chord = v0 * tau * np.sinc(half / np.pi)
    mid = psi0 + half
    return x0 + chord * np.sin(mid), y0 + chord * np.cos(mid), speed, psi0 + omega * tau, omega


def _integrate_mixed(seg: Segment, start: tuple[float, float, float, float], tau: np.ndarray):
    """States at local times tau for a section with both a_t and a turn (ODE, DOP853)."""
    a = seg.tangential_accel

    def rhs(_t, s):
        x, y, v, psi = s
        return [v * math.sin(psi), v * math.cos(psi), a, float(turn_rate_rad_s(seg, v))]

    times, back = np.unique(tau, return_inverse=True)
    sol = solve_ivp(
        rhs, (0.0, seg.duration_s), list(start), method="DOP853",
        t_eval=times, rtol=ODE_RTOL, atol=ODE_ATOL,
    )
    if not sol.success:  # pragma: no cover - DOP853 on this smooth field does not fail
        raise RuntimeError(f"trajectory integration failed: {sol.message}")
    x, y, speed, psi = sol.y[:, back]
    return x, y, speed, psi, turn_rate_rad_s(seg, speed)


def _section(seg: Segment, start: tuple[float, float, float, float], tau: np.ndarray):
    if seg.kind == "mixed":
        return _integrate_mixed(seg, start, tau)
    return _closed_form(seg, start, tau)


def evaluate(target: Target, t: np.ndarray) -> KinematicState:
    """Noise-free states of ``target`` at target times ``t`` (s, shape (n,)).

    Times must lie in [0, target.duration_s]; a time on a section boundary
    takes the earlier section (both give the same position and speed).
    """
    t = np.asarray(t, dtype=float)
    if t.size and (t.min() < -1e-9 or t.max() > target.duration_s + 1e-9):
        raise ValueError(f"times outside the trajectory of {target.name!r} (0..{target.duration_s} s)")
    n = t.size
    x, y, speed, heading, omega, accel = (np.empty(n) for _ in range(6))
    start = (target.x_m, target.y_m, target.speed_m_s, math.radians(target.heading_deg))
    t0 = 0.0
    done = np.zeros(n, dtype=bool)
    for seg in target.segments:
        t1 = t0 + seg.duration_s
        sel = ~done & (t <= t1 + 1e-9)
        tau_end = np.array([seg.duration_s])
        if sel.any():
            tau = np.clip(t[sel] - t0, 0.0, seg.duration_s)
            xs, ys, vs, ps, ws = _section(seg, start, np.concatenate([tau, tau_end]))
            x[sel], y[sel], speed[sel], heading[sel], omega[sel] = xs[:-1], ys[:-1], vs[:-1], ps[:-1], ws[:-1]
            accel[sel] = seg.tangential_accel
            done |= sel
            start = (xs[-1], ys[-1], vs[-1], ps[-1])
        else:
            xs, ys, vs, ps, _ = _section(seg, start, tau_end)
            start = (xs[0], ys[0], vs[0], ps[0])
        t0 = t1
    return KinematicState(t, x, y, speed, heading, omega, accel)
