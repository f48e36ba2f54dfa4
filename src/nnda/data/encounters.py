"""Seeded multi-target training scenes: targets that meet, training data that looks like tracking.

The 17 training presets hold one target each, so another target's contact
near a track is never a negative training pair. These scenes put two or
three targets through a meeting point P (m, 8-25 km from the radar) at
time ``t_meet`` (s), in one of three geometries:

* ``crossing``: headings 30-150 deg apart, all through P at ``t_meet``;
* ``parallel``: one heading, side by side 300-1,500 m apart abreast of P;
* ``near-miss``: as crossing, but the second target passes 150-800 m wide
  of P.

Targets fly straight to the meeting (speeds 80-250 m/s), then keep straight
or turn (normal acceleration up to 10 m/s^2, either side) for the rest of
the 120 s scene; the clutter is the presets' calibrated default (100 points
per scan in a square on the targets). Usage::

    scenes = encounter_scenes(24, seed=0)     # list of 24 Scenario, geometries in turn
    datasets = [generate(s, seed=0) for s in scenes]
"""

from __future__ import annotations

import math

import numpy as np

from nnda.data.scenario import Scenario, Segment, Target
from nnda.errors import ConfigError

GEOMETRIES = ("crossing", "parallel", "near-miss")
DURATION_S = 120.0


def _target(name: str, rng: np.random.Generator, meet: np.ndarray, t_meet: float, heading_deg: float,
            offset_m: float) -> Target:
    """A target through ``meet`` + ``offset_m`` to its right at ``t_meet`` s, then straight or turning."""
    speed = float(rng.uniform(80.0, 250.0))
    h = math.radians(heading_deg)
    ahead, right = np.array([math.sin(h), math.cos(h)]), np.array([math.cos(h), -math.sin(h)])
    start = meet + offset_m * right - speed * t_meet * ahead
    turn = float(rng.uniform(-10.0, 10.0)) if rng.random() < 0.5 else 0.0
    after = DURATION_S - t_meet
    segments = [Segment(duration_s=t_meet), Segment(duration_s=after / 2),
                Segment(duration_s=after / 2, normal_accel=turn or None)]
    return Target(name=name, x_m=float(start[0]), y_m=float(start[1]), heading_deg=heading_deg % 360.0,
                  speed_m_s=speed, segments=segments)


def encounter_scene(index: int, seed: int) -> Scenario:
    """Scene ``index`` (its geometry is GEOMETRIES[index % 3]) drawn from ``SeedSequence([seed, index])``."""
    if index < 0 or seed < 0:
        raise ConfigError(f"encounter scenes: index and seed must be >= 0, got {index}, {seed}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, index]))
    geometry = GEOMETRIES[index % len(GEOMETRIES)]
    r, az = rng.uniform(8_000.0, 25_000.0), rng.uniform(0.0, 2 * math.pi)
    meet = np.array([r * math.sin(az), r * math.cos(az)])
    t_meet = float(rng.uniform(40.0, 70.0))
    heading = float(rng.uniform(0.0, 360.0))
    n = 3 if rng.random() < 0.3 else 2
    targets = []
    for i in range(n):
        if geometry == "parallel":
            h, offset = heading, i * float(rng.uniform(300.0, 1_500.0))
        else:
            h = heading + i * float(rng.uniform(30.0, 150.0)) * rng.choice([-1.0, 1.0])
            offset = 0.0 if geometry == "crossing" or i == 0 else float(rng.uniform(150.0, 800.0))
        targets.append(_target(f"{geometry}-{i}", rng, meet, t_meet, h, offset))
    return Scenario(name=f"encounter{index:03d}-{geometry}", duration_s=DURATION_S, targets=targets,
                    seed=seed, description=f"{geometry} of {n} targets at scan {t_meet / 2:.0f}, seed {seed}")


def encounter_scenes(count: int, seed: int = 0) -> list[Scenario]:
    """``count`` scenes, geometries in turn (module docstring)."""
    if count < 0:
        raise ConfigError(f"encounter scenes: count must be >= 0, got {count}")
    return [encounter_scene(i, seed) for i in range(count)]
