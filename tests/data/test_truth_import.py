"""A truth file without vx, vy: velocities derived from each target's positions (`nnda.data.truth_import`)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nnda.data.detections_import import read_detections
from nnda.errors import BoundWarning, ConfigError, DatasetError

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


# ----------------------------------------------------------------------------- truth from labelled reports

AIS = [{"kind": "position", "reports": True, "scan_period_s": 10.0, "sigma_position_m": 10.0}]


def _reports(tmp_path, rows: list[tuple[float, str, float, float]]) -> object:
    """reports.csv: time, target_id (empty: clutter), x, y, rows as given (in time order)."""
    path = tmp_path / "reports.csv"
    path.write_text("time,target_id,x,y\n" + "".join(f"{t},{label},{x},{y}\n" for t, label, x, y in rows))
    return path


def test_truth_from_labels_interpolates_each_labels_reports_at_the_window_ends(tmp_path):
    # A moves x = 5 t, y = 100 - 2 t, reported at uneven times: one report on a window's end (10 s), two at 7 s
    # (the first counts), then 11.7 s without a report around 20 s; B turns between its reports at 8 and 11 s
    # and is silent 14 s after; a clutter row has no label
    a = lambda t: (t, "A", 5.0 * t, 100.0 - 2.0 * t)  # noqa: E731
    rows = [a(1.5), a(7.0), (7.0, "A", 9999.0, 9999.0), (8.0, "B", 0.0, 50.0), (9.0, "", 300.0, 300.0), a(10.0),
            (11.0, "B", 30.0, 20.0), a(13.2), a(24.9), (25.0, "B", 500.0, 500.0)]
    ds = read_detections(_reports(tmp_path, rows), sensors=AIS, truth_from_labels=12.0)
    names = [t.name for t in ds.scenario.targets]
    assert names == ["A", "B"] and ds.scan_time.tolist() == [10.0, 20.0, 30.0]
    tr = ds.truth
    got = {(names[k], float(t)): (x, y, vx, vy) for k, t, x, y, vx, vy in
           zip(tr.target_id, tr.time, tr.x, tr.y, tr.vx, tr.vy)}
    assert sorted(got) == [("A", 10.0), ("A", 20.0), ("B", 10.0)]  # A at 30 s, B at 20 s: no report after
    np.testing.assert_allclose(got["A", 10.0], (50.0, 80.0, 5.0, -2.0))
    np.testing.assert_allclose(got["A", 20.0], (100.0, 60.0, 5.0, -2.0))
    np.testing.assert_allclose(got["B", 10.0], (20.0, 30.0, 10.0, -10.0))
    assert tr.detected.tolist() == [True, True, True]
    # a gap of 11.7 s is too long under 11 s: A has no row at 20 s
    short = read_detections(_reports(tmp_path, rows), sensors=AIS, truth_from_labels=11.0).truth
    assert sorted(zip(short.target_id.tolist(), short.time.tolist())) == [(0, 10.0), (1, 10.0)]


def test_truth_from_labels_matches_a_label_by_label_reference_on_many_reports(tmp_path):
    rng = np.random.default_rng(3)
    n = 4000
    t = np.sort(rng.uniform(0.1, 600.0, n)).round(1)  # repeated times, some on the windows' ends
    labels = rng.choice([f"S{i}" for i in range(40)], n)
    x, y = rng.normal(0, 5000, n).round(1), rng.normal(0, 5000, n).round(1)
    ds = read_detections(_reports(tmp_path, list(zip(t, labels, x, y))), sensors=AIS, truth_from_labels=30.0)
    names = [s.name for s in ds.scenario.targets]
    want = {}
    for name in names:  # the reference: per label and scan time, the two reports around it
        mine = np.flatnonzero(labels == name)
        tm, first = np.unique(t[mine], return_index=True)  # a label's first report of each time counts
        xm, ym = x[mine][first], y[mine][first]
        for time in np.unique(ds.scan_time):
            j = np.searchsorted(tm, time, side="right") - 1  # the last report at or before
            ok = 0 <= j < tm.size - 1 and tm[j + 1] - tm[j] <= 30.0
            if not ok and 1 <= j and tm[j] == time and tm[j] - tm[j - 1] <= 30.0:
                j, ok = j - 1, True  # on a report: the pair that ends there
            if ok:
                w = (time - tm[j]) / (tm[j + 1] - tm[j])
                want[name, time] = (xm[j] + w * (xm[j + 1] - xm[j]), ym[j] + w * (ym[j + 1] - ym[j]),
                                    (xm[j + 1] - xm[j]) / (tm[j + 1] - tm[j]))
    tr = ds.truth
    got = {(names[k], float(s)): (a, b, c) for k, s, a, b, c in zip(tr.target_id, tr.time, tr.x, tr.y, tr.vx)}
    assert got.keys() == want.keys() and len(got) > 500
    np.testing.assert_allclose([got[k] for k in want], [want[k] for k in want], rtol=1e-12, atol=1e-9)


def test_a_dataset_with_truth_from_labels_is_scored(tmp_path):
    from nnda.study.track import run_tracker

    # three aircraft at 104 m/s, a report each 10 s window: interpolated truth at every window's end but the last
    rows = sorted((t + 0.1 * i, f"V{i}", 3000.0 * i + 100.0 * t + 5000.0, 8000.0 - 30.0 * t) for i in range(3)
                  for t in np.arange(1.0, 300.0, 10.0))
    ds = read_detections(_reports(tmp_path, rows), sensors=AIS, truth_from_labels=20.0)
    assert np.unique(ds.truth.target_id).size == 3 and ds.truth.scan.size == 3 * 29
    scores = run_tracker(ds, "gnn").scores.values
    assert scores["hit_rate"] > 90.0 and scores["false_tracks"] == 0 and scores["gospa"] < 200.0


def test_truth_from_labels_refuses_no_labels_a_bad_gap_and_a_truth_file(tmp_path):
    path = _reports(tmp_path, [(1.0, "A", 5.0, 0.0), (4.0, "A", 10.0, 0.0), (6.0, "A", 20.0, 0.0)])
    for gap in (0.0, -5.0, float("nan"), float("inf"), "60", True):
        with pytest.raises(ConfigError, match="--truth-from-labels .*: must be a positive number of seconds"):
            read_detections(path, sensors=AIS, truth_from_labels=gap)
    (tmp_path / "truth.csv").write_text("time,target_id,x,y\n10,A,0,0\n")
    with pytest.raises(ConfigError, match="--truth-from-labels 60 with --truth .*truth.csv: give one source"):
        read_detections(path, sensors=AIS, truth_from_labels=60, truth=tmp_path / "truth.csv")
    (tmp_path / "bare.csv").write_text("time,x,y\n1,5,0\n4,10,0\n")
    with pytest.raises(ConfigError, match=r"--truth-from-labels 60: .*bare.csv has no labelled reports \(column "
                                          r"'target_id' is missing\)"):
        read_detections(tmp_path / "bare.csv", sensors=AIS, truth_from_labels=60)
    (tmp_path / "clutter.csv").write_text("time,x,y,target_id\n1,5,0,\n4,10,0,-1\n")
    with pytest.raises(ConfigError, match="clutter.csv has no labelled reports .*empty or negative in every row"):
        read_detections(tmp_path / "clutter.csv", sensors=AIS, truth_from_labels=60)
    with pytest.raises(ConfigError, match=r"--truth-from-labels 1: no label has two reports at most 1 s apart .*"
                                          r"median gap between a label's reports is 2.5 s"):
        read_detections(path, sensors=AIS, truth_from_labels=1)


def test_the_command_takes_truth_from_labels(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from nnda.app.cli import app

    monkeypatch.chdir(tmp_path)
    _reports(tmp_path, [(1.0, "A", 5.0, 0.0), (4.0, "A", 10.0, 0.0), (9.0, "B", 5.0, 5.0), (12.0, "A", 40.0, 0.0)])
    done = CliRunner().invoke(app, ["import-detections", "reports.csv", "--out", "ds", "--sensor", "kind=position",
                                    "--sensor", "reports=true", "--sensor", "scan_period_s=10",
                                    "--truth-from-labels", "10"])
    assert done.exit_code == 0, done.output
    assert "1 truth rows" in done.output and "truth from the labels: 1 of the 2 labels have truth rows" in done.output
    bad = CliRunner().invoke(app, ["import-detections", "reports.csv", "--out", "ds2", "--truth-from-labels", "-1"])
    assert isinstance(bad.exception, ConfigError) and "--truth-from-labels -1: must be a positive" in str(bad.exception)
