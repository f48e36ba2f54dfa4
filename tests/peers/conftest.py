"""Shared scenes of the peers tests. Tests that need Stone Soup (the ``nnda[peers]`` extra, also in
``dev``) skip themselves without it; those about its absence run either way."""

from __future__ import annotations

import pytest

from nnda.data.scenario import Clutter, Scenario, Segment, Target


@pytest.fixture
def three_targets() -> Scenario:
    """Three well separated targets, one of them turning gently, 25 scans, no clutter."""
    return Scenario(name="three", duration_s=50.0, clutter=Clutter(law="none"), targets=[
        Target(name="east", x_m=-12_000.0, y_m=14_000.0, heading_deg=90.0, speed_m_s=150.0,
               segments=[Segment(duration_s=50.0)]),
        Target(name="south", x_m=8_000.0, y_m=12_000.0, heading_deg=180.0, speed_m_s=120.0,
               segments=[Segment(duration_s=20.0), Segment(duration_s=30.0, turn_rate_deg_s=1.0)]),
        Target(name="north", x_m=2_000.0, y_m=-20_000.0, heading_deg=10.0, speed_m_s=200.0,
               segments=[Segment(duration_s=50.0)]),
    ])
