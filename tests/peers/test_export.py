"""nnda's tracks and truth as Stone Soup objects: every state is its table row, exactly; Stone Soup's own GOSPA
and OSPA on them equal nnda's per scan; bad tables and arguments are refused by name."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from datetime import datetime, timedelta

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest

import nnda
from nnda.data.dataset import write_dataset
from nnda.errors import ConfigError, DatasetError
from nnda.study.metrics import run_metrics
from nnda.study.track import COV_COLUMNS, COV_ENTRIES, STATE, run_tracker

#: Stone Soup timestamps of second t without a time origin (`nnda.peers.adapter.EPOCH` + t)
EPOCH = datetime(2000, 1, 1)


@pytest.fixture(scope="module")
def s1():
    """S1 (100 scans, clutter, four targets) and gnn's run on it: confirmed, preliminary and deleted rows."""
    ds = nnda.generate("S1", seed=3)
    return ds, run_tracker(ds, "gnn")


def _rows(table: pa.Table, statuses: tuple[str, ...]) -> dict[int, dict[str, np.ndarray]]:
    """The table's rows of ``statuses`` by track id, in table order: time, state (n, 4), covariance (n, 4, 4)."""
    keep = np.isin(np.array(table["status"].to_pylist(), dtype=object), statuses)
    tid = table["track_id"].to_numpy()[keep]
    cols = {c: table[c].to_numpy()[keep] for c in (*STATE, *COV_COLUMNS, "time", "scan")}
    out = {}
    for t in np.unique(tid):
        at = tid == t
        cov = np.empty((at.sum(), 4, 4))
        for c, (i, j) in zip(COV_COLUMNS, COV_ENTRIES):
            cov[:, i, j] = cov[:, j, i] = cols[c][at]
        out[int(t)] = {"time": cols["time"][at], "scan": cols["scan"][at], "cov": cov,
                       "state": np.column_stack([cols[c][at] for c in STATE]),
                       "status": np.array(table["status"].to_pylist(), dtype=object)[keep][at]}
    return out


def _assert_exact(tracks, table: pa.Table, statuses: tuple[str, ...], origin: datetime = EPOCH) -> None:
    """Every exported state is its row: the same vector, covariance and time, the track's id, its status."""
    from stonesoup.types.state import GaussianState

    rows = _rows(table, statuses)
    assert [t.id for t in tracks] == [str(t) for t in sorted(rows)]
    for track in tracks:
        want = rows[int(track.id)]
        assert len(track.states) == len(want["time"])
        assert all(type(s) is GaussianState for s in track.states)
        np.testing.assert_array_equal(np.array([np.asarray(s.state_vector).ravel() for s in track.states]),
                                      want["state"])
        np.testing.assert_array_equal(np.array([np.asarray(s.covar) for s in track.states]), want["cov"])
        assert [s.timestamp for s in track.states] == [origin + timedelta(seconds=t) for t in want["time"].tolist()]
        assert [m["status"] for m in track.metadatas] == want["status"].tolist()
        assert [m["scan"] for m in track.metadatas] == want["scan"].tolist()
        assert track.metadata["status"] == want["status"][-1]


def test_confirmed_states_are_the_table_rows_exactly(s1):
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    ds, run = s1
    statuses = set(run.table["status"].to_pylist())
    assert statuses == {"preliminary", "confirmed", "deleted"}  # the filter has rows to leave out
    tracks = nnda.to_stonesoup(run.table, ds)
    n_confirmed = run.table["status"].to_pylist().count("confirmed")
    assert sum(len(t) for t in tracks) == n_confirmed > 200
    confirmed = np.array(run.table["status"].to_pylist()) == "confirmed"
    assert len(tracks) == np.unique(run.table["track_id"].to_numpy()[confirmed]).size >= 4
    _assert_exact(tracks, run.table, ("confirmed",))
    assert nnda.to_stonesoup(run.table)[0].states[0].timestamp == tracks[0].states[0].timestamp  # no dataset: EPOCH


def test_the_statuses_filter_keeps_preliminary_rows_never_deleted_ones(s1):
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    ds, run = s1
    both = ("confirmed", "preliminary")
    tracks = nnda.to_stonesoup(run.table, ds, statuses=both)
    status = run.table["status"].to_pylist()
    assert sum(len(t) for t in tracks) == len(status) - status.count("deleted")
    _assert_exact(tracks, run.table, both)
    prelim = nnda.to_stonesoup(run.table, ds, statuses="preliminary")
    assert sum(len(t) for t in prelim) == status.count("preliminary")
    assert {m["status"] for t in prelim for m in t.metadatas} == {"preliminary"}


def test_a_parquet_or_csv_file_gives_the_same_tracks(s1, tmp_path):
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    ds, run = s1
    pq.write_table(run.table.append_column("lat", pa.array(np.zeros(run.table.num_rows))), tmp_path / "tracks.parquet")
    pacsv.write_csv(run.table, tmp_path / "tracks.csv")
    for path in (tmp_path / "tracks.parquet", str(tmp_path / "tracks.csv")):
        _assert_exact(nnda.to_stonesoup(path, ds), run.table, ("confirmed",))


def test_a_dataset_with_a_time_origin_gives_absolute_times(s1, tmp_path):
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    ds, run = s1
    dated = write_dataset(replace(ds, time_origin_utc="2016-01-12T13:02:10.25Z"), tmp_path / "dated")
    origin = datetime(2016, 1, 12, 13, 2, 10, 250000)
    tracks = nnda.to_stonesoup(run.table, dated)  # the directory: read with its manifest's origin
    _assert_exact(tracks, run.table, ("confirmed",), origin)
    truth = nnda.truth_to_stonesoup(dated)
    first = truth[0].states[0]
    assert first.timestamp == origin + timedelta(seconds=float(ds.truth.time[0])) and first.timestamp.tzinfo is None


def test_truth_paths_are_the_truth_rows(s1):
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    from stonesoup.types.groundtruth import GroundTruthState

    ds, _ = s1
    paths = nnda.truth_to_stonesoup(ds)
    t = ds.truth
    assert [p.id for p in paths] == [target.name for target in ds.scenario.targets]
    assert sum(len(p) for p in paths) == t.scan.size
    for i, path in enumerate(paths):
        at = t.target_id == i
        assert all(type(s) is GroundTruthState for s in path.states)
        np.testing.assert_array_equal(np.array([np.asarray(s.state_vector).ravel() for s in path.states]),
                                      np.column_stack([t.x, t.vx, t.y, t.vy])[at])
        assert [s.timestamp for s in path.states] == [EPOCH + timedelta(seconds=v) for v in t.time[at].tolist()]
        assert [s.metadata["detected"] for s in path.states] == t.detected[at].tolist()
        assert {s.metadata["target_id"] for s in path.states} == {i}


@pytest.mark.parametrize("cutoff", [1000.0, 100.0])
def test_stone_soups_gospa_and_ospa_equal_nndas_per_scan(s1, cutoff):
    """Stone Soup's metric generators on the exported confirmed tracks and truth, positions only (mapping
    (0, 2)), p = 2, alpha = 2: each time's GOSPA and its parts, and OSPA, equal nnda's at that scan; at the
    scans Stone Soup leaves out (no track, no target) nnda's are 0. At c = 100 m some assigned pairs are
    beyond the cut-off."""
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.manager import MultiManager
    from stonesoup.metricgenerator.ospametric import GOSPAMetric, OSPAMetric

    ds, run = s1
    ours = run_metrics(ds, run.outputs, cutoff_m=cutoff).series
    assert (ours["gospa_missed"] > 0).any() and (ours["gospa_false"] > 0).any()
    manager = MultiManager([GOSPAMetric(c=cutoff, p=2, measure=Euclidean((0, 2))),
                            OSPAMetric(c=cutoff, p=2, measure=Euclidean((0, 2)))])
    manager.add_data({"tracks": nnda.to_stonesoup(run.table, ds), "groundtruth_paths": nnda.truth_to_stonesoup(ds)})
    metrics = manager.generate_metrics()
    scan_of = {EPOCH + timedelta(seconds=t): k for k, t in enumerate(ds.scan_time.tolist())}
    gospa = metrics["gospa_generator"]["GOSPA Metrics"].value
    ospa = metrics["ospa_generator"]["OSPA distances"].value
    seen = np.array([scan_of[m.timestamp] for m in gospa])
    assert [scan_of[m.timestamp] for m in ospa] == seen.tolist()
    assert 50 < seen.size < ds.n_scans
    for key, part in (("gospa", "distance"), ("gospa_localisation", "localisation"),
                      ("gospa_missed", "missed"), ("gospa_false", "false")):
        theirs = np.array([m.value[part] for m in gospa])
        np.testing.assert_allclose(theirs, ours[key][seen], rtol=1e-9, atol=1e-9 * cutoff ** 2, err_msg=key)
    np.testing.assert_allclose([m.value for m in ospa], ours["ospa"][seen], rtol=1e-9, atol=1e-9 * cutoff)
    left_out = np.setdiff1d(np.arange(ds.n_scans), seen)
    assert np.all(ours["gospa"][left_out] == 0) and np.all(ours["ospa"][left_out] == 0)


def test_stone_soups_motion_model_reads_the_state_as_x_vx_y_vy(s1):
    """Stone Soup's 2-D constant-velocity model moves an exported state's x by vx dt and y by vy dt; its Kalman
    smoother refuses the tracks (no prior kept) rather than smoothing with wrong ones."""
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.smoother.kalman import KalmanSmoother

    ds, run = s1
    track = max(nnda.to_stonesoup(run.table, ds), key=len)
    cv = CombinedLinearGaussianTransitionModel([ConstantVelocity(1.0), ConstantVelocity(1.0)])
    x, vx, y, vy = np.asarray(track.state_vector, float).ravel()
    moved = np.asarray(cv.function(track.state, noise=False, time_interval=timedelta(seconds=2)), float).ravel()
    # Stone Soup's matrix product against ours: two code paths, equal to ~1e-9 on any CPU
    np.testing.assert_allclose(moved, [x + 2 * vx, vx, y + 2 * vy, vy], rtol=1e-9)
    with pytest.raises(TypeError, match="GaussianStatePredictions or GaussianStateUpdates"):
        KalmanSmoother(transition_model=cv).smooth(track)


def test_bad_tables_are_refused_by_name(s1, tmp_path):
    pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    ds, run = s1
    with pytest.raises(ConfigError, match=r"the track table: not a track table of nnda: column\(s\) cov_x_vy, "
                                          r"detection missing"):
        nnda.to_stonesoup(run.table.drop_columns(["cov_x_vy", "detection"]))
    detections = write_dataset(ds, tmp_path / "s1") / "detections.parquet"
    with pytest.raises(ConfigError, match=rf"{detections}: not a track table of nnda: column\(s\) track_id"):
        nnda.to_stonesoup(detections)
    (tmp_path / "tracks.json").write_text("{}")
    with pytest.raises(ConfigError, match=r"tracks.json: unknown file type '.json'"):
        nnda.to_stonesoup(tmp_path / "tracks.json")
    with pytest.raises(DatasetError, match=r"nowhere.parquet: no such file"):
        nnda.to_stonesoup(tmp_path / "nowhere.parquet")
    with pytest.raises(ConfigError, match=r"a directory; give the track file in it, e.g. .*tracks.parquet"):
        nnda.to_stonesoup(tmp_path)
    x = run.table["x"].to_numpy().copy()
    x[7] = np.nan
    with pytest.raises(DatasetError, match=r"the track table: row 8 \(1-based\), column 'x': nan"):
        nnda.to_stonesoup(run.table.set_column(run.table.schema.get_field_index("x"), "x", pa.array(x)))
    status = run.table["status"].to_pylist()
    status[3] = "lost"
    with pytest.raises(DatasetError, match=r"row 4 \(1-based\), column 'status': 'lost', not one of tentative"):
        nnda.to_stonesoup(run.table.set_column(3, "status", pa.array(status)))
    with pytest.raises(DatasetError, match=r"the track table: row \d+ \(1-based\): scan 16, but the dataset has "
                                           r"scans 1-15: tracks of another dataset\?"):
        nnda.to_stonesoup(run.table, nnda.generate("train08", seed=0))
    late = pa.array(run.table["time"].to_numpy() + 0.5)
    k = run.table["scan"][0].as_py()
    t = float(ds.scan_time[k - 1])
    with pytest.raises(DatasetError, match=rf"row 1 \(1-based\): scan {k} at {t + 0.5!r} s, but the dataset's scan {k} "
                                           rf"is at {t!r} s"):
        nnda.to_stonesoup(run.table.set_column(1, "time", late), ds)


@pytest.mark.parametrize("statuses, message", [
    ("deleted", "names 'deleted': a deleted track's row is its report in the scan that deletes it"),
    (["confirmed", "lost"], "names 'lost', not a track status"),
    ([], "argument 'statuses' is \\[\\]"),
    (2, "argument 'statuses' is 2"),
])
def test_bad_statuses_are_refused_by_name(s1, statuses, message):
    with pytest.raises(ConfigError, match=message):
        nnda.to_stonesoup(s1[1].table, statuses=statuses)


def test_bad_arguments_are_refused_by_name(s1):
    with pytest.raises(ConfigError, match="nnda.to_stonesoup: argument 'tracks' is 3 of type int"):
        nnda.to_stonesoup(3)
    with pytest.raises(ConfigError, match="nnda.to_stonesoup: argument 'dataset' is 2.5 of type float"):
        nnda.to_stonesoup(s1[1].table, 2.5)
    with pytest.raises(ConfigError, match="nnda.truth_to_stonesoup: argument 'dataset' is None"):
        nnda.truth_to_stonesoup(None)


def test_without_stone_soup_the_calls_name_the_extra(s1, monkeypatch):
    monkeypatch.setitem(sys.modules, "stonesoup", None)  # import stonesoup now fails, as when not installed
    for call in (lambda: nnda.to_stonesoup(s1[1].table), lambda: nnda.truth_to_stonesoup(s1[0])):
        with pytest.raises(ConfigError, match=r"needs Stone Soup, which is not installed .*'nnda\[peers\]'"):
            call()


def test_importing_nnda_and_its_api_does_not_import_stone_soup():
    code = ("import sys, nnda; nnda.to_stonesoup, nnda.truth_to_stonesoup; import nnda.app.api; "
            "assert 'stonesoup' not in sys.modules, 'imported'")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
