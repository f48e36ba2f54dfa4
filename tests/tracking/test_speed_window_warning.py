"""The initiation window's v_max refuses faster targets: counted per run and warned once (BoundWarning), nothing
else changed."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.errors import BoundWarning
from nnda.tracking.lifecycle import LifecycleConfig, fast_lines, fast_tolerance_m, no_lines
from nnda.tracking.registry import make_tracker


def _scene(speed: float, clutter: int = 30, pd: float | None = None) -> Scenario:
    """One target flying east at ``speed`` m/s for 40 s, 10 km north of the radar, over ``clutter`` contacts a scan."""
    target = Target(name="F", x_m=-4_000.0, y_m=10_000.0, heading_deg=90.0, speed_m_s=speed, pd=pd,
                    segments=[Segment(duration_s=40.0)])
    return Scenario(name="fast", duration_s=40.0, targets=[target], clutter=Clutter(count=clutter), seed=3)


def _run(kind: str, scenario: Scenario, params: dict | None = None, run: int = 0):
    dataset = generate(scenario, run=run)
    tracker = make_tracker(kind, dataset.scenario.sensors, params)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outputs = [tracker.step(scan) for scan in dataset.scans()]
    bound = [w for w in caught if issubclass(w.category, BoundWarning)]
    return tracker, outputs, bound


@pytest.mark.parametrize("kind", ["gnn", "jpda", "mht"])
def test_a_target_faster_than_v_max_is_counted_and_warned_once(kind):
    tracker, outputs, bound = _run(kind, _scene(320.0))
    assert not any(o.confirmed.any() for o in outputs)  # the window never lets it start
    assert tracker.initiation.n_too_fast >= 1
    assert len(bound) == 1
    message = str(bound[0].message)
    assert message.startswith(f"{kind}, t = ")
    assert "lifecycle.v_max = 200 m/s (config field)" in message and "Raise lifecycle.v_max" in message
    assert "490 to 890 m apart" in message
    tracker.reset()
    assert tracker.initiation.n_too_fast == 0


def test_raising_v_max_tracks_it_without_a_warning():
    tracker, outputs, bound = _run("gnn", _scene(320.0), {"lifecycle": {"v_max": 400.0}})
    assert sum(int(o.confirmed.sum()) for o in outputs) > 10
    assert tracker.initiation.n_too_fast == 0 and not bound


def test_slow_targets_in_clutter_raise_no_warning():
    for run in range(3):
        tracker, _, bound = _run("gnn", _scene(180.0, clutter=100), run=run)
        assert tracker.initiation.n_too_fast == 0 and not bound


def test_the_count_changes_no_output(monkeypatch):
    """Counting reads the scan only: every output is the same with the count switched off (a fast annulus 5 cm
    wide, which no pair of this scene falls in)."""
    scene = _scene(320.0)
    _, counted, bound = _run("gnn", scene)
    assert bound
    window = LifecycleConfig.fast_window

    def narrow(self, period, sigma):
        d_max = window(self, period, sigma)[0]
        return d_max, d_max + 0.05
    monkeypatch.setattr(LifecycleConfig, "fast_window", narrow)
    _, plain, bound = _run("gnn", scene)
    assert not bound
    for a, b in zip(counted, plain, strict=True):
        for field in ("track_id", "status", "state", "covariance", "contact"):
            assert np.array_equal(getattr(a, field), getattr(b, field))


def test_a_clean_line_counts_at_its_sixth_contact():
    """Without clutter each continuation is worth -ln(pi tol^2 / A) = 1.8 at T = 2 s and sigma = 30 m: the line
    passes ln 1000 at four continuations, its sixth contact; a seventh counts no new line."""
    cfg = LifecycleConfig()
    d_max, d_fast = cfg.fast_window(2.0, 30.0)
    tol = fast_tolerance_m(30.0, 2.0)
    lines, counts = no_lines(), []
    points = [np.array([[600.0 * k, 50.0 * k]]) for k in range(8)]  # 604 m a scan: 302 m/s
    for before, now in zip(points, points[1:]):
        n, lines = fast_lines(before, now, np.array([0]), np.zeros(1, bool), lines, d_max, d_fast, tol, 2.0)
        counts.append(n)
    assert counts == [0, 0, 0, 0, 1, 0, 0]


def test_a_line_bent_beyond_the_tolerance_does_not_count():
    cfg = LifecycleConfig()
    d_max, d_fast = cfg.fast_window(2.0, 30.0)
    tol = fast_tolerance_m(30.0, 2.0)
    lines, total = no_lines(), 0
    # 600 m a scan, turning 40 degrees a scan: each contact lies about 410 m off the straight extrapolation
    heading = np.radians(40.0) * np.arange(8)
    xy = np.cumsum(np.stack([600.0 * np.cos(heading), 600.0 * np.sin(heading)], axis=1), axis=0)
    for k in range(7):
        n, lines = fast_lines(xy[k:k + 1], xy[k + 1:k + 2], np.array([0]), np.zeros(1, bool), lines, d_max, d_fast,
                              tol, 2.0)
        total += n
    assert total == 0


def test_the_count_reaches_the_scores_and_the_results_table(tmp_path):
    """``too_fast_lines`` goes into ``nnda track``'s scores.json record and a study's results.parquet column."""
    from nnda.study.track import run_tracker, scores_record
    from nnda.study.track_job import scalars, series
    from nnda.study.track_results import results_table

    dataset = generate(_scene(320.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BoundWarning)
        run = run_tracker(dataset, "gnn")
    record = scores_record(run, dataset, {}, 1_000.0)
    lines = record["track_management"]["too_fast_lines"]
    assert lines >= 1 and record["track_management"]["confirmation"] == run.management["confirmation"]
    assert set(record["track_management"]["deletions"]) == set(run.management["deletions"])
    base = {"scenario": "fast", "tracker": "gnn", "kind": "gnn", "run": 0, "seed": 0, "dataset_digest": "d",
            "n_scans": dataset.n_scans, "n_targets": 1, "ownership": "contacts", "metrics": scalars(run.scores),
            "series": series(run.scores)}
    older = {k: v for k, v in run.management.items() if k != "too_fast_lines"}  # a record kept before the count
    table = results_table([base | {"track_management": run.management}, base | {"track_management": older}, base])
    assert table.column("too_fast_lines").to_pylist() == [lines, None, None]
