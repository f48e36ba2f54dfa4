"""Stone Soup peers through our Tracker interface and registry."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, TrackingError
from nnda.study.config import study_from_dict
from nnda.study.metrics import run_metrics
from nnda.study.plan import plan_study
from nnda.tracking.output import NO_CONTACT, TrackStatus
from nnda.tracking.registry import PEERS, TRACKERS, make_tracker

try:
    import stonesoup  # noqa: F401
except ImportError:
    HAVE_STONESOUP = False
else:
    HAVE_STONESOUP = True
#: the tests about a missing Stone Soup run either way; the others need it
needs_stonesoup = pytest.mark.skipif(not HAVE_STONESOUP,
                                     reason="Stone Soup is not installed: pip install 'nnda[peers]'")


#: the peers that associate contacts (scored by the contacts their tracks used); the GM-PHD peer reports none
CONTACT_PEERS = sorted(set(PEERS) - {"stonesoup-gmphd"})


@needs_stonesoup
@pytest.mark.parametrize("name", CONTACT_PEERS)
def test_tracks_every_target_without_clutter(name, three_targets):
    ds = generate(three_targets, seed=1)
    tracker = make_tracker(name, ds.scenario.sensor)
    outs = [tracker.step(scan) for scan in ds.scans()]
    m = run_metrics(ds, outs)
    assert (m.confirmed_tracks, m.false_tracks, m.lost_targets, m.track_breaks) == (3, 0, 0, 0)
    assert m.hit_rate > 95.0 and m.position_rmse_m < 80.0
    for scan, o in zip(ds.scans(), outs):
        assert np.unique(o.track_id).size == len(o)
        used = o.contact[o.contact >= 0]
        assert used.max(initial=-1) < len(scan.measurements)
        assert o.state.shape == (len(o), 4) and o.covariance.shape == (len(o), 4, 4)


@needs_stonesoup
def test_gmphd_peer_follows_every_target_like_ours(three_targets):
    """Stone Soup's GM-PHD, set up as our ekphd, reports the same targets with the same accuracy."""
    ds = generate(three_targets, seed=1)
    scores = {}
    for name in ("stonesoup-gmphd", "ekphd"):
        tracker = make_tracker(name, ds.scenario.sensor)
        outs = [tracker.step(scan) for scan in ds.scans()]
        assert all((o.contact == NO_CONTACT).all() and (o.status == TrackStatus.CONFIRMED).all() for o in outs)
        assert tracker.cardinality.map is None and tracker.cardinality.extracted == len(outs[-1])
        scores[name] = run_metrics(ds, outs, ownership="position")
    ss, ours = scores["stonesoup-gmphd"], scores["ekphd"]
    assert (ss.false_tracks, ss.track_breaks, ss.id_switches) == (0, 0, 0) and ss.mota >= 0.9
    assert ss.position_rmse_m < 60.0 and abs(ss.position_rmse_m - ours.position_rmse_m) < 5.0


@needs_stonesoup
def test_statuses_ids_and_deletions(small_scenario):
    ds = generate(small_scenario, seed=2)
    a, b = ([tracker.step(s) for s in ds.scans()]
            for tracker in (make_tracker("stonesoup-gnn", ds.scenario.sensor) for _ in range(2)))
    for x, y in zip(a, b):  # the same data gives the same output, ids included
        np.testing.assert_array_equal(x.track_id, y.track_id)
        np.testing.assert_array_equal(x.state, y.state)
    deleted = np.concatenate([o.track_id[o.status == TrackStatus.DELETED] for o in a])
    assert deleted.size and np.unique(deleted).size == deleted.size  # reported once
    for k in range(1, len(a)):
        gone = a[k - 1].track_id[a[k - 1].status == TrackStatus.DELETED]
        assert not np.isin(a[k].track_id, gone).any()
    seen = np.concatenate([o.status for o in a])
    assert {TrackStatus.PRELIMINARY, TrackStatus.CONFIRMED} <= set(seen.tolist())


@needs_stonesoup
def test_bad_scans_are_refused():
    tracker = make_tracker("stonesoup-jpda", Sensor())
    tracker.step(Scan(1, 2.0, np.empty((0, 2))))
    with pytest.raises(TrackingError, match="does not come after"):
        tracker.step(Scan(2, 2.0, np.array([[10_000.0, 1.0]])))
    with pytest.raises(TrackingError, match="contact 1 is invalid"):
        tracker.step(Scan(2, 4.0, np.array([[10_000.0, 1.0], [np.nan, 0.5]])))


@needs_stonesoup
def test_peers_are_registered_but_not_listed_with_the_built_in_trackers():
    assert all(name in TRACKERS for name in PEERS)
    assert not set(PEERS) & set(TRACKERS)  # loops over TRACKERS see the built-in trackers only
    with pytest.raises(ConfigError, match="sigma_q"):
        make_tracker("stonesoup-gnn", Sensor(), {"sigma_q": -1})


def test_missing_extra_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "stonesoup", None)  # as if Stone Soup were not installed
    with pytest.raises(ConfigError, match=r"pip install 'nnda\[peers\]'"):
        make_tracker("stonesoup-gnn", Sensor())
    study = study_from_dict({"runs": 1, "trackers": {"gnn": {"kind": "gnn"}, "ss": {"kind": "stonesoup-gnn"}},
                             "scenarios": [{"preset": "S1"}]})
    with pytest.raises(ConfigError, match=r"tracker 'ss'.*needs Stone Soup.*pip install 'nnda\[peers\]'"):
        plan_study(study)


def test_nnda_does_not_import_stonesoup():
    import subprocess

    code = ("import sys, nnda, nnda.app.cli, nnda.tracking, nnda.study.compare, nnda.reports.study_report; "
            "assert 'stonesoup' not in sys.modules, 'imported'")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
