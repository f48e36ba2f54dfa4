"""GNN's two options for dense clutter: preliminary tracks sharing contacts (duplicates merged) and the score
peaks a fixed-lag output ends deleted tracks at (JPDA's, the neural tracker's and MHT's too)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import nnda
from nnda.data.generator import generate
from nnda.data.scenario import Scenario
from nnda.tracking.gnn import GNNConfig, _merged
from nnda.tracking.lag import EndsAtScorePeak, FixedLag
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY
from nnda.tracking.registry import make_tracker
from nnda.tracking.tracks import P2, T2

MN = {"lifecycle": {"confirmation": "mn", "quality_deletion": False}}
BOTH = {"shared_preliminary": True, "end_at_score_peak": True}


@pytest.fixture(scope="module")
def dense():
    """S3's first 60 scans with 1,000 clutter points a scan (the clutter sweep's scene)."""
    path = Path(nnda.__file__).parent / "studies" / "clutter-sweep" / "S3-c1000.json"
    scene = Scenario.model_validate_json(path.read_text()).model_copy(update={"duration_s": 120.0})
    return generate(scene, 0, 0)


def _outputs(tracker, ds):
    return [tracker.step(scan) for scan in ds.scans()]


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        for field in ("track_id", "status", "state", "covariance", "contact"):
            assert np.array_equal(getattr(x, field), getattr(y, field)), (x.scan, field)


def test_both_options_are_on_by_default():
    config = GNNConfig()
    assert config.shared_preliminary and config.end_at_score_peak


def test_merged_keeps_each_tracks_cheapest_contact_and_drops_the_duplicate_of_lower_score():
    # tracks 0 and 1 held the same last contact and both take contact 5: 1 scores 2 - 0.5 / 2 after it, 0
    # scores 10 - 1 / 2, so 1 is the duplicate; track 2 takes 5 too, from another last contact: kept
    r, c = np.array([0, 0, 1, 1, 2]), np.array([5, 6, 5, 7, 5])
    cost = np.array([1.0, 2.0, 0.5, 3.0, 4.0])
    last = np.zeros((3, 8))  # `Tracks.history`: the last contact's position and time
    last[:, P2], last[:, T2] = [[100.0, 200.0], [100.0, 200.0], [100.0, 300.0]], 4.0
    rows, cols, dupes = _merged(r, c, cost, np.array([10.0, 2.0, 0.0]), last)
    assert rows.tolist() == [0, 2] and cols.tolist() == [5, 5] and dupes.tolist() == [1]
    # the other way round when track 1 scores higher
    rows, cols, dupes = _merged(r, c, cost, np.array([1.0, 2.0, 0.0]), last)
    assert rows.tolist() == [1, 2] and dupes.tolist() == [0]
    # equal scores after the contact: the lower row keeps it; the cheapest of a track's pairs is its pick
    rows, cols, dupes = _merged(r, c, np.array([1.0, 2.0, 1.0, 0.5, 4.0]), np.array([2.0, 2.0, 0.0]), last)
    assert rows.tolist() == [0, 1, 2] and cols.tolist() == [5, 7, 5] and dupes.tolist() == []
    rows, cols, dupes = _merged(r, c, np.array([1.0, 2.0, 1.0, 3.0, 4.0]), np.array([2.0, 2.0, 0.0]), last)
    assert rows.tolist() == [0, 2] and dupes.tolist() == [1]


def test_shared_preliminary_tracks_share_contacts_but_no_two_hold_the_same_last_two(dense):
    tracker = make_tracker("gnn", dense.scenario.sensors, {"shared_preliminary": True})
    shared = 0
    for scan in dense.scans():
        out = tracker.step(scan)
        live = (out.status == PRELIMINARY) & (out.contact != NO_CONTACT)
        taken = out.contact[live]
        shared += taken.size - np.unique(taken).size
        tracks = tracker.tracks
        if tracks is None:
            continue
        both = tracks.history[tracks.status == PRELIMINARY][:, :6]  # the last two contacts: position, time
        assert np.unique(both, axis=0).shape[0] == both.shape[0], scan.index
    assert shared > 0
    assert tracker.n_merged > 0
    assert tracker.deletions["unconfirmed"] > 0


def test_under_the_mn_rule_the_options_change_nothing(dense):
    plain = _outputs(make_tracker("gnn", dense.scenario.sensors, MN), dense)
    opted = make_tracker("gnn", dense.scenario.sensors, {**MN, **BOTH})
    opted.keep_score_peaks()
    _same(plain, _outputs(opted, dense))
    assert opted.n_merged == 0
    assert isinstance(opted, EndsAtScorePeak)
    assert all(ids.size == 0 for ids, _ in (opted.score_peaks(o) for o in plain))


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_end_at_score_peak_leaves_the_online_outputs_alone(dense, name):
    plain = _outputs(make_tracker(name, dense.scenario.sensors, {"end_at_score_peak": False}), dense)
    peaks = make_tracker(name, dense.scenario.sensors, {"end_at_score_peak": True})
    peaks.keep_score_peaks()
    _same(plain, _outputs(peaks, dense))


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_score_peaks_are_kept_only_when_asked(dense, name):
    """An online run (nothing asked for them) keeps no score peaks and tells none."""
    tracker = make_tracker(name, dense.scenario.sensors, {"end_at_score_peak": True})
    told = [tracker.score_peaks(tracker.step(scan))[0].size for scan in dense.scans()]
    assert sum(told) == 0 and tracker._peaks[0].size == 0


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_score_peaks_lie_in_each_deleted_tracks_life(dense, name):
    tracker = make_tracker(name, dense.scenario.sensors, {"end_at_score_peak": True})
    tracker.keep_score_peaks()
    born, told = {}, 0
    for scan in dense.scans():
        out = tracker.step(scan)
        for i in out.track_id.tolist():
            born.setdefault(i, out.time)
        ids, time = tracker.score_peaks(out)
        assert ids.tolist() == out.track_id[out.status == DELETED].tolist()
        for i, t in zip(ids.tolist(), time.tolist()):
            assert born[i] - 2.0 <= t < out.time  # from its first contact (a scan before its birth) to before now
        told += ids.size
    assert told > 0


@pytest.mark.parametrize("tracker", ["gnn", "jpda", "nn", "mht"])
def test_the_lag_ends_deleted_tracks_at_their_score_peak(tracker, request):
    """Over the whole of S3 at 1,000 clutter points a scan (nn: with the test scorer)."""
    path = Path(nnda.__file__).parent / "studies" / "clutter-sweep" / "S3-c1000.json"
    dense = generate(Scenario.model_validate_json(path.read_text()), 0, 0)
    own = {"model": str(request.getfixturevalue("model_file"))} if tracker == "nn" else {}
    runs = {}
    for name, params in (("plain", {"end_at_score_peak": False}), ("peak", {"end_at_score_peak": True})):
        fixed = FixedLag(make_tracker(tracker, dense.scenario.sensors, {**own, **params}), 3)
        lagged = [late for late in (fixed.step(scan)[1] for scan in dense.scans()) if late is not None]
        runs[name] = lagged + fixed.flush()
    confirmed = {name: {(o.scan, i) for o in outs for i, s in zip(o.track_id.tolist(), o.status.tolist())
                        if s == CONFIRMED} for name, outs in runs.items()}
    assert confirmed["peak"] < confirmed["plain"]  # only ever fewer confirmed reports, and some fewer
