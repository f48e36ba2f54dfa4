"""A truth file without vx, vy: velocities derived from each target's positions (`nnda.data.truth_import`)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nnda.data.detections_import import read_detections
from nnda.errors import BoundWarning, DatasetError

POSITION = [{"kind": "position", "scan_period_s": 1.0, "sigma_position_m": 10.0}]


def _files(tmp_path, truth: list[tuple[float, str, float, float]]) -> None:
    """det.csv: one detection per truth row (at its position); truth.csv: time, target_id, x, y (no vx, vy),
    rows in the given order."""
    (tmp_path / "det.csv").write_text("time,x,y,target_id\n" + "".join(
        f"{t},{x + 1.0},{y},{label}\n" for t, label, x, y in sorted(truth)))
    (tmp_path / "truth.csv").write_text("time,target_id,x,y\n" + "".join(
        f"{t},{label},{x},{y}\n" for t, label, x, y in truth))


def test_velocities_are_central_differences_per_target_one_sided_at_the_ends_and_0_alone(tmp_path):
    a = [(t, "A", 3.0 * t * t, -40.0 * t + 7.0) for t in (1.0, 2.0, 4.0, 5.0, 9.0)]  # uneven steps
    b = [(t, "B", 1000.0 - 2.0 * t, 5.0 * t + 2000.0) for t in range(1, 7)]
    c = [(3.0, "C", 500.0, 500.0)]  # one row: velocity 0
    rows = [b[3], a[2], c[0], a[0], b[0], a[4], b[5], a[1], b[1], b[2], a[3], b[4]]  # interleaved, shuffled
    _files(tmp_path, rows)
    with pytest.warns(BoundWarning, match=r"truth.csv: no vx, vy columns: the velocities are derived from each "
                                          r"target's positions; 1 target\(s\) with one row get velocity 0") as caught:
        ds = read_detections(tmp_path / "det.csv", sensors=POSITION, truth=tmp_path / "truth.csv")
    assert len([w for w in caught if w.category is BoundWarning]) == 1
    names = [s.name for s in ds.scenario.targets]
    tr = ds.truth
    for label, rows_of in (("A", a), ("B", b), ("C", c)):
        mine = tr.target_id == names.index(label)
        t, x, y = (np.array([r[i] for r in rows_of]) for i in (0, 2, 3))
        want = (np.gradient(x, t), np.gradient(y, t)) if t.size > 1 else (np.zeros(1), np.zeros(1))
        np.testing.assert_allclose(tr.time[mine], t)
        np.testing.assert_allclose(tr.vx[mine], want[0], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(tr.vy[mine], want[1], rtol=1e-12, atol=1e-9)
    inner = (tr.target_id == names.index("A")) & (tr.time == 4.0)
    assert float(tr.vx[inner][0]) == pytest.approx(24.0)  # exact for a quadratic on uneven steps
    np.testing.assert_allclose(tr.vy[tr.target_id == names.index("B")], 5.0)


def test_every_target_with_several_rows_warns_nothing(tmp_path):
    _files(tmp_path, [(t, "A", 10.0 * t, 0.0) for t in (1.0, 2.0, 3.0)])
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundWarning)
        ds = read_detections(tmp_path / "det.csv", sensors=POSITION, truth=tmp_path / "truth.csv")
    np.testing.assert_allclose(ds.truth.vx, 10.0)
    assert ds.scenario.targets[0].speed_m_s == pytest.approx(10.0) and ds.scenario.targets[0].heading_deg == 90.0


def test_a_target_with_two_rows_at_one_time_is_refused_before_dividing_by_zero(tmp_path):
    _files(tmp_path, [(1.0, "A", 0.0, 0.0), (2.0, "A", 10.0, 0.0), (2.0, "A", 11.0, 0.0)])
    with pytest.raises(DatasetError, match=r"truth.csv: data row 3 \(line 4\), column 'time': target 'A' has a second "
                                           r"row at the time of data row 2; one row per target per scan"):
        read_detections(tmp_path / "det.csv", sensors=POSITION, truth=tmp_path / "truth.csv")


def test_one_velocity_column_without_the_other_is_refused(tmp_path):
    _files(tmp_path, [(1.0, "A", 0.0, 0.0), (2.0, "A", 10.0, 0.0)])
    lines = (tmp_path / "truth.csv").read_text().splitlines()
    (tmp_path / "truth.csv").write_text("\n".join([lines[0] + ",vx", *(s + ",10" for s in lines[1:])]) + "\n")
    with pytest.raises(DatasetError, match=r"required column\(s\) 'vy' missing \(a truth file has time, target_id, "
                                           r"x, y \(or lat, lon\), and vx, vy or neither\)"):
        read_detections(tmp_path / "det.csv", sensors=POSITION, truth=tmp_path / "truth.csv")


def test_many_targets_in_shuffled_rows_each_get_their_own_differences(tmp_path):
    """200,000 rows of 50,000 targets, shuffled: x = 3 t^2 + target offset at t = 1, 2, 4, 5 s gives vx 9, 12,
    24, 27 m/s (one-sided, central on uneven steps, one-sided) whatever the offset."""
    from nnda.data.truth_import import derived_velocities

    n_targets = 50_000
    t = np.tile(np.array([1.0, 2.0, 4.0, 5.0]), n_targets)
    target = np.repeat(np.arange(n_targets), 4)
    shuffle = np.random.default_rng(3).permutation(t.size)
    t, target = t[shuffle], target[shuffle]
    labels = np.array([str(i) for i in range(n_targets)], dtype=object)[target]
    vx, vy = derived_velocities(tmp_path / "truth.csv", "time", t, labels, 3.0 * t * t + 1e3 * target,
                                np.zeros_like(t))
    want = np.select([t == 1.0, t == 2.0, t == 4.0], [9.0, 12.0, 24.0], 27.0)
    np.testing.assert_allclose(vx, want, rtol=1e-9)
    assert not vy.any()
