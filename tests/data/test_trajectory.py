"""Kinematics of generated trajectories against their configs and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nnda.data.presets import PRESETS, TRAINING_TRAJECTORIES, _target
from nnda.data.scenario import Segment, Target
from nnda.data.trajectory import evaluate

DT = 0.01  # s, finite-difference step


def _kinematics(target: Target, t: np.ndarray):
    """Speed, tangential acceleration and turn rate (rad/s, right positive) from positions alone."""
    h = 1e-3
    p = [evaluate(target, t + d) for d in (-h, 0.0, h)]
    vx = (p[2].x - p[0].x) / (2 * h)
    vy = (p[2].y - p[0].y) / (2 * h)
    ax = (p[2].x - 2 * p[1].x + p[0].x) / h**2
    ay = (p[2].y - 2 * p[1].y + p[0].y) / h**2
    speed = np.hypot(vx, vy)
    a_t = (vx * ax + vy * ay) / speed
    # heading clockwise from north: omega = d psi/dt = (vy ax - vx ay) / V^2
    omega = (vy * ax - vx * ay) / speed**2
    return speed, a_t, omega


def _interiors(target: Target, n: int = 25):
    """Sample times well inside each segment (avoiding the kinks at the boundaries)."""
    t0 = 0.0
    for seg in target.segments:
        yield seg, np.linspace(t0 + 0.05, t0 + seg.duration_s - 0.05, n)
        t0 += seg.duration_s


@pytest.mark.parametrize("name", sorted(TRAINING_TRAJECTORIES))
def test_training_trajectory_kinematics_match_config(name):
    target = _target(name, TRAINING_TRAJECTORIES[name], -5000.0, 8000.0, 45.0, [])
    speed0 = target.speed_m_s
    t0 = 0.0
    for seg, t in _interiors(target):
        speed, a_t, omega = _kinematics(target, t)
        expected_speed = speed0 + seg.tangential_accel * (t - t0)
        np.testing.assert_allclose(speed, expected_speed, rtol=1e-6)
        np.testing.assert_allclose(a_t, seg.tangential_accel, atol=2e-3)
        expected_omega = (seg.normal_accel or 0.0) / expected_speed
        np.testing.assert_allclose(omega, expected_omega, atol=2e-6)
        speed0 += seg.tangential_accel * seg.duration_s
        t0 += seg.duration_s


def test_constant_turn_rate_segment():
    target = Target(name="r", x_m=0.0, y_m=10_000.0, heading_deg=0.0, speed_m_s=100.0,
                    segments=[Segment(duration_s=30.0, tangential_accel=2.0, turn_rate_deg_s=-3.0)])
    _, a_t, omega = _kinematics(target, np.linspace(1, 29, 15))
    np.testing.assert_allclose(omega, math.radians(-3.0), atol=1e-6)
    np.testing.assert_allclose(a_t, 2.0, atol=2e-3)


def test_turn_matches_circle_geometry():
    """A right turn at V, omega is a clockwise circle of radius V / omega."""
    v, a_n = 99.0, 5.0
    target = Target(name="c", x_m=0.0, y_m=10_000.0, heading_deg=0.0, speed_m_s=v,
                    segments=[Segment(duration_s=200.0, normal_accel=a_n)])
    radius = v**2 / a_n
    s = evaluate(target, np.linspace(0, 200, 101))
    # heading north, turning right: the centre lies east of the start
    np.testing.assert_allclose(np.hypot(s.x - radius, s.y - 10_000.0), radius, rtol=1e-9)
    np.testing.assert_allclose(s.heading, a_n / v * s.t, rtol=1e-9)


def test_mixed_section_ode_agrees_with_closed_form():
    """With a_t and a_n both constant, psi = psi0 + k ln(V/V0), k = a_n/a_t, and
    x, y integrate exactly; the ODE solver must match to millimetres."""
    v0, a_t, a_n, psi0 = 85.0, 3.0, 5.0, math.radians(45.0)
    target = Target(name="m", x_m=1000.0, y_m=2000.0, heading_deg=45.0, speed_m_s=v0,
                    segments=[Segment(duration_s=30.0, tangential_accel=a_t, normal_accel=a_n)])
    t = np.linspace(0.0, 30.0, 16)
    s = evaluate(target, t)
    k = a_n / a_t
    u = np.log((v0 + a_t * t) / v0)
    psi = psi0 + k * u
    scale = v0**2 / (a_t * (4 + k**2))
    x = 1000.0 + scale * (np.exp(2 * u) * (2 * np.sin(psi) - k * np.cos(psi)) - (2 * np.sin(psi0) - k * np.cos(psi0)))
    y = 2000.0 + scale * (np.exp(2 * u) * (2 * np.cos(psi) + k * np.sin(psi)) - (2 * np.cos(psi0) + k * np.sin(psi0)))
    np.testing.assert_allclose(s.x, x, atol=1e-3)
    np.testing.assert_allclose(s.y, y, atol=1e-3)
    np.testing.assert_allclose(s.heading, psi, atol=1e-9)
    np.testing.assert_allclose(s.speed, v0 + a_t * t, rtol=1e-9)


def test_straight_acceleration_closed_form():
    target = Target(name="a", x_m=0.0, y_m=-9000.0, heading_deg=90.0, speed_m_s=85.0,
                    segments=[Segment(duration_s=30.0, tangential_accel=4.0)])
    s = evaluate(target, np.array([0.0, 10.0, 30.0]))
    np.testing.assert_allclose(s.x, 85.0 * s.t + 2.0 * s.t**2, atol=1e-9)
    np.testing.assert_allclose(s.y, -9000.0, atol=1e-9)


@pytest.mark.parametrize("name, degrees", [("TR2", 289), ("TR3", 202), ("TR9", 369), ("TR10", -357), ("TR12", 186)])
def test_heading_changes_quoted_by_the_spec(name, degrees):
    target = _target(name, TRAINING_TRAJECTORIES[name], 0.0, 10_000.0, 0.0, [])
    end = evaluate(target, np.array([target.duration_s]))
    assert math.degrees(end.heading[0]) == pytest.approx(degrees, abs=1.5)


def test_training_09_placement_spec_radius():
    """TR9's full circle has a radius of about 3.36 km."""
    speed, sections = TRAINING_TRAJECTORIES["TR9"]
    assert speed**2 / sections[0][2] == pytest.approx(3360, rel=0.01)


segment_strategy = st.builds(
    Segment,
    duration_s=st.floats(1.0, 60.0),
    tangential_accel=st.sampled_from([0.0, -2.0, 1.5, 4.0]),
    normal_accel=st.sampled_from([None, -10.0, 3.0, 12.0]),
)


@settings(max_examples=40, deadline=None)
@given(segments=st.lists(segment_strategy, min_size=1, max_size=4), heading=st.floats(0, 360))
def test_any_segment_list_is_continuous_and_keeps_speed_law(segments, heading):
    speed0 = 500.0  # stays positive under the strongest deceleration drawn (-2 m/s^2 for 240 s)
    target = Target(name="h", x_m=0.0, y_m=15_000.0, heading_deg=heading, speed_m_s=speed0, segments=segments)
    bounds = np.cumsum([0.0] + [s.duration_s for s in segments])
    eps = 1e-7
    before = evaluate(target, np.clip(bounds - eps, 0, target.duration_s))
    after = evaluate(target, np.clip(bounds + eps, 0, target.duration_s))
    np.testing.assert_allclose(before.x, after.x, atol=1e-3)
    np.testing.assert_allclose(before.y, after.y, atol=1e-3)
    expected = speed0 + np.cumsum([0.0] + [s.tangential_accel * s.duration_s for s in segments])
    np.testing.assert_allclose(evaluate(target, bounds).speed, expected, rtol=1e-9)


def test_times_outside_the_trajectory_are_refused():
    target = PRESETS["train01"].targets[0]
    with pytest.raises(ValueError, match="outside the trajectory"):
        evaluate(target, np.array([target.duration_s + 1.0]))
