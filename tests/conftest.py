"""Shared fixtures: small scenarios built from the public config API."""

from __future__ import annotations

import pytest

from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Target


def straight_target(name: str = "A", **kw) -> Target:
    base = dict(name=name, x_m=-10_000.0, y_m=10_000.0, heading_deg=90.0, speed_m_s=100.0,
                segments=[Segment(duration_s=40.0)])
    base.update(kw)
    return Target(**base)


@pytest.fixture
def small_scenario() -> Scenario:
    """Two targets, 20 scans, light clutter: fast to generate and to write."""
    return Scenario(
        name="small", duration_s=40.0, seed=3,
        targets=[straight_target("A"),
                 straight_target("B", x_m=12_000.0, y_m=-8_000.0, heading_deg=200.0,
                                 segments=[Segment(duration_s=20.0), Segment(duration_s=20.0, normal_accel=5.0)],
                                 missed_scans=[4, 5])],
        clutter=Clutter(count=10),
        process_noise=ProcessNoise(),
    )
