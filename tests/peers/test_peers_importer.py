"""Scenes simulated by Stone Soup become nnda datasets our reader accepts and our trackers follow."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from nnda.data.dataset import read_dataset
from nnda.errors import ConfigError

pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")

from nnda.peers.importer import StoneSoupScene, import_stonesoup, simulate  # noqa: E402
from nnda.study.metrics import run_metrics  # noqa: E402
from nnda.tracking.registry import make_tracker  # noqa: E402

SMALL = StoneSoupScene(n_scans=30, targets=3, birth_rate=0.0, clutter=20.0)


def test_written_dataset_passes_the_reader(tmp_path):
    path = import_stonesoup(tmp_path / "ss", SMALL, seed=5)
    ds = read_dataset(path)
    assert ds.n_scans == 30 and ds.seed == 5 and len(ds.scenario.targets) == 3
    d, t = ds.detections, ds.truth
    assert np.all(np.diff(d.scan) >= 0) and np.all((d.azimuth >= 0) & (d.azimuth < 2 * np.pi))
    assert np.all((d.range >= ds.scenario.sensor.min_range_m) & (d.range <= ds.scenario.sensor.max_range_m))
    np.testing.assert_allclose(np.hypot(d.x, d.y), d.range)
    np.testing.assert_array_equal(d.time, d.scan * ds.scenario.sensor.scan_period_s)
    # a truth row is detected exactly when its target has a contact in that scan
    has = {(int(k), int(i)) for k, i in zip(d.scan[~d.is_clutter], d.target_id[~d.is_clutter])}
    assert [(int(k), int(i)) in has for k, i in zip(t.scan, t.target_id)] == t.detected.tolist()
    # target contacts lie near their target (30 m, 3 mrad noise)
    rows = {(int(k), int(i)): (x, y) for k, i, x, y in zip(t.scan, t.target_id, t.x, t.y)}
    err = [np.hypot(x - rows[k, i][0], y - rows[k, i][1])
           for k, i, x, y in zip(d.scan, d.target_id, d.x, d.y) if i >= 0]
    assert max(err) < 500.0


def test_seeded_and_tracked_by_ours():
    a, b, c = simulate(SMALL, seed=1), simulate(SMALL, seed=1), simulate(SMALL, seed=2)
    np.testing.assert_array_equal(a.detections.range, b.detections.range)
    np.testing.assert_array_equal(a.truth.x, b.truth.x)
    assert a.detections.range.size != c.detections.range.size or not np.array_equal(a.detections.range,
                                                                                      c.detections.range)
    outs = [tracker.step(s) for tracker in [make_tracker("gnn", a.scenario.sensor)] for s in a.scans()]
    m = run_metrics(a, outs)
    assert m.confirmed_tracks - m.false_tracks >= 3 and m.lost_targets == 0


def test_bad_scene_is_refused():
    with pytest.raises(ConfigError, match="clutter >= 0"):
        simulate(StoneSoupScene(clutter=-1.0))


def test_cli(tmp_path):
    out = subprocess.run([sys.executable, "-m", "nnda", "import-stonesoup", "--out", "ss", "--seed", "3",
                          "--scans", "15", "--clutter", "10"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert read_dataset(tmp_path / "ss").n_scans == 15
