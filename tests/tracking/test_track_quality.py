"""Track-quality deletion: a confirmed track whose gate is expected to hold more clutter contacts than the
association can resolve (``lifecycle.max_gate_clutter``) is deleted, counted as "quality"."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.data.sensor import cart_to_polar
from nnda.errors import ConfigError
from nnda.filters.imm import IMMState
from nnda.reports.deletions_section import deletions
from nnda.study.checksums import write_checksums
from nnda.study.track_results import RESULTS_FILE
from nnda.tracking.lifecycle import (
    DELETION_REASONS,
    SANITY_REASONS,
    LifecycleConfig,
    gate_clutter,
    position_sd,
    sanity_reasons,
)
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker

SENSOR = Sensor()  # polar, 30 m range noise (its least), 2 s scans
QUALITY = SANITY_REASONS.index("quality") + 1


def _state(sd: float, speed: float = 150.0) -> tuple[np.ndarray, np.ndarray]:
    """One track at (8 km, 12 km) with a round position sd ``sd`` (m)."""
    x = np.array([[8_000.0, speed, 12_000.0, 0.0]])
    return x, np.diag([sd**2, 20.0**2, sd**2, 20.0**2])[None]


def test_gate_clutter_against_a_hand_computation():
    P = np.zeros((1, 4, 4))
    P[0, 0, 0], P[0, 2, 2], P[0, 0, 2], P[0, 2, 0] = 1e6, 4e5, 2e5, 2e5
    # pi x gate x sqrt(det(P_xy + 30^2 I)) x density
    hand = 1e-6 * math.pi * 9.21 * math.sqrt((1e6 + 900.0) * (4e5 + 900.0) - 2e5**2)
    assert hand == pytest.approx(17.39, abs=0.01)
    assert gate_clutter(P, np.array([1e-6]), 30.0, 9.21) == pytest.approx([hand], rel=1e-12)


def test_the_rule_deletes_past_the_bound_only():
    x, P = _state(300.0)
    n_c = gate_clutter(P, np.ones(1), 30.0, 9.21)[0]  # per unit density
    cfg = LifecycleConfig()
    assert cfg.max_gate_clutter == 2.0

    def code(density, cfg=cfg, x=x, P=P):
        return int(sanity_reasons(x, P, (SENSOR,), 9.21, cfg, None if density is None else np.array([density]))[0])

    assert code(2.5 / n_c) == QUALITY  # 2.5 clutter contacts expected in the gate
    assert code(1.5 / n_c) == 0
    assert code(0.0) == 0 and code(None) == 0  # not judged (a preliminary track), no density
    assert code(2.5 / n_c, LifecycleConfig(max_gate_clutter=None)) == 0
    assert code(2.5 / n_c, LifecycleConfig(max_gate_clutter=3.0)) == 0
    big_x, big_P = _state(2_500.0)
    assert code(1.0, x=big_x, P=big_P) == SANITY_REASONS.index("covariance") + 1  # the absolute limit first
    fast_x, _ = _state(300.0, speed=600.0)
    assert code(2.5 / n_c, x=fast_x) == SANITY_REASONS.index("speed") + 1


def test_the_bound_is_a_checked_config_field():
    with pytest.raises(ConfigError, match="max_gate_clutter"):
        make_tracker("jpda", SENSOR, {"lifecycle": {"max_gate_clutter": 0}})


def _polar(xy: np.ndarray) -> np.ndarray:
    r, azimuth = cart_to_polar(xy[:, 0], xy[:, 1])
    return np.column_stack([r, azimuth])


def _jpda_after_clutter(inflate_sd: float, max_gate_clutter: float | None = 2.0):
    """A JPDA (M/N) track confirmed on a target at 150 m/s, its position covariance then grown by ``inflate_sd``
    (m) on both axes, and a scan with the target's contact among 60 clutter contacts in the 6 km square
    around it (1.7 per km^2). Returns the last output and the tracker."""
    tracker = make_tracker("jpda", SENSOR, {"lifecycle": {"confirmation": "mn", "max_gate_clutter": max_gate_clutter}})
    start, velocity = np.array([8_000.0, 12_000.0]), np.array([150.0, 0.0])
    for k in range(1, 7):
        out = tracker.step(Scan(k, 2.0 * k, _polar((start + velocity * 2.0 * k)[None]), 0))
    assert out.status.tolist() == [TrackStatus.CONFIRMED]
    if inflate_sd:
        f = tracker.tracks.filt
        P = f.P.copy()
        P[..., 0, 0] += inflate_sd**2
        P[..., 2, 2] += inflate_sd**2
        tracker.tracks = replace(tracker.tracks, filt=IMMState(f.x, P, f.mu))
    target = start + velocity * 14.0
    clutter = target + np.random.default_rng(0).uniform(-3_000.0, 3_000.0, (60, 2))
    return tracker.step(Scan(7, 14.0, _polar(np.vstack([target[None], clutter])), 0)), tracker


def test_a_bloated_jpda_track_is_deleted_with_the_counted_reason():
    out, tracker = _jpda_after_clutter(600.0)
    assert out.status[0] == TrackStatus.DELETED
    assert 600.0 < position_sd(out.covariance[:1])[0] < 2_000.0  # not the absolute limit's case
    assert tracker.deletions["quality"] == 1
    assert sum(tracker.deletions.values()) == 1
    kept, off = _jpda_after_clutter(600.0, max_gate_clutter=None)  # the same track without the rule lives on
    assert kept.status[0] == TrackStatus.CONFIRMED and off.deletions["quality"] == 0


def test_a_clean_jpda_track_in_the_same_clutter_is_kept():
    out, tracker = _jpda_after_clutter(0.0)
    assert out.status[0] == TrackStatus.CONFIRMED
    assert position_sd(out.covariance[:1])[0] < 100.0
    assert tracker.deletions["quality"] == 0


def test_quality_is_a_counted_deletion_reason():
    assert "quality" in SANITY_REASONS and "quality" in DELETION_REASONS
    assert "quality" in make_tracker("gnn", SENSOR).track_management()["deletions"]


def test_the_deletions_table_reads_a_study_written_before_the_quality_reason(tmp_path):
    older = [r for r in DELETION_REASONS if r != "quality"]
    table = pa.table({"tracker": ["gnn", "gnn"], "confirmation": ["mn", "mn"],
                      **{f"deleted_{r}": [2, 4] for r in older}})
    pq.write_table(table, tmp_path / RESULTS_FILE)
    write_checksums(tmp_path, [RESULTS_FILE], "test")
    rule, per = deletions(tmp_path)["gnn"]
    assert rule == "mn" and per == {r: 3.0 for r in older}


def test_the_rule_reads_the_unexplained_clutter_where_the_tracker_does():
    """Thirty airliners under a 10 s radar, no clutter, a wide gate: counted as clutter, each aircraft's own
    contact puts a coasting track's gate past the bound (local estimate: dozens of quality deletions); with
    ``clutter_estimate = "unexplained"`` the confirmed tracks' expected detections are left out of the count,
    and no track of this clutter-free scene is deleted for quality."""
    rng = np.random.default_rng(0)
    targets = []
    for i in range(30):
        r, b = rng.uniform(60e3, 200e3), rng.uniform(0, 2 * np.pi)
        legs = [Segment(duration_s=300.0), Segment(duration_s=60.0, normal_accel=float(rng.choice([-5, 5]))),
                Segment(duration_s=240.0)]
        targets.append(Target(name=f"a{i}", x_m=r * np.sin(b), y_m=r * np.cos(b), segments=legs,
                              heading_deg=float(rng.uniform(0, 360)), speed_m_s=float(rng.uniform(200, 260))))
    radar = Sensor(scan_period_s=10.0, max_range_m=250e3, min_range_m=5e3, sigma_range_m=50.0,
                   sigma_azimuth_mrad=1.5, pd=0.9, clutter=Clutter(law="none"))
    ds = generate(Scenario(name="air", duration_s=600.0, targets=targets, sensors=(radar,)), seed=0)
    quality = {}
    for estimate in ("local", "unexplained"):
        tracker = make_tracker("gnn", radar, {"clutter_estimate": estimate, "gate": 50.0,
                                              "lifecycle": {"v_max": 400.0, "max_position_sd_m": 10_000.0}})
        for scan in ds.scans():
            tracker.step(scan)
        quality[estimate] = tracker.deletions["quality"]
    assert quality["local"] >= 10 and quality["unexplained"] == 0, quality
