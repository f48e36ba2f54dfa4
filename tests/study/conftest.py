"""A small study on disk: two short scenario configs, two GNN variants, a few runs."""

from __future__ import annotations

import pytest

SCENARIO = """
name = "{name}"
duration_s = {duration}
seed = 3
[clutter]
count = {clutter}
[[targets]]
name = "a"
x_m = -10000
y_m = 10000
heading_deg = 90
speed_m_s = 100
segments = [{{duration_s = {duration}}}]
[[targets]]
name = "b"
x_m = 12000
y_m = -8000
heading_deg = 200
speed_m_s = 120
segments = [{{duration_s = 20}}, {{duration_s = {rest}, normal_accel = 5.0}}]
missed_scans = [6, 7]
"""

STUDY = """
name = "small"
seed = 5
runs = {runs}

[trackers.gnn]
kind = "gnn"

[trackers.gnn-tight]
kind = "gnn"
params = {{ gate = 6.0 }}

[[scenarios]]
config = "scenarios/one.toml"
[[scenarios]]
config = "scenarios/two.toml"
"""


def write_small_study(root, runs: int = 3, duration: int = 40, clutter: int = 15):
    """Write the study file (and its scenario configs) under ``root``; returns the study file."""
    (root / "scenarios").mkdir(parents=True, exist_ok=True)
    for name in ("one", "two"):
        (root / "scenarios" / f"{name}.toml").write_text(
            SCENARIO.format(name=name, duration=duration, rest=duration - 20, clutter=clutter))
    path = root / "study.toml"
    path.write_text(STUDY.format(runs=runs))
    return path


@pytest.fixture(scope="session")
def write_study():
    """`write_small_study`, for tests that need other sizes or several copies."""
    return write_small_study


@pytest.fixture
def small_study(tmp_path):
    return write_small_study(tmp_path)
