"""Run metrics on hand-made tracker outputs with known answers."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Target
from nnda.study.metrics import OutputError, run_metrics
from nnda.tracking.output import TrackerOutput
from nnda.tracking.output import TrackStatus as S


@pytest.fixture(scope="module")
def dataset():
    targets = [Target(name=n, x_m=x, y_m=12_000.0, heading_deg=90.0, speed_m_s=100.0,
                      segments=[Segment(duration_s=40.0)]) for n, x in (("A", -10_000.0), ("B", 5_000.0))]
    sc = Scenario(name="m", duration_s=40.0, targets=targets, clutter=Clutter(law="annulus", count=3),
                  process_noise=ProcessNoise(model="none"))
    return generate(sc, seed=1)


class Builder:
    """Tracker outputs made by hand: tracks follow contacts chosen by the test."""

    def __init__(self, ds):
        self.ds, self.rows = ds, defaultdict(list)
        self.bounds = ds.scan_bounds()

    def contact(self, k, target):
        """Row of target's contact in scan k (or a clutter contact for target=-1)."""
        det = self.ds.detections
        rows = np.flatnonzero((det.scan == k) & (det.target_id == target))
        return int(rows[0])

    def add(self, k, track, status, row=None, xy=None):
        det = self.ds.detections
        if xy is None:
            xy = (det.x[row], det.y[row])
        meas = -1 if row is None else row - self.bounds[k - 1]
        self.rows[k].append((track, status, xy, meas))

    def outputs(self):
        out = []
        for k in range(1, self.ds.n_scans + 1):
            rows = self.rows[k]
            state = np.array([[x, 0.0, y, 0.0] for _, _, (x, y), _ in rows]).reshape(-1, 4)
            out.append(TrackerOutput(k, 2.0 * k, np.array([r[0] for r in rows], np.int64),
                                     np.array([r[1] for r in rows], np.int8), state,
                                     np.zeros((len(rows), 4, 4)), np.array([r[3] for r in rows], np.int64)))
        return out


def _truth_xy(ds, k, target):
    t = ds.truth
    i = np.flatnonzero((t.scan == k) & (t.target_id == target))[0]
    return t.x[i], t.y[i]


def perfect(ds, b):
    for target in (0, 1):
        for k in range(2, 21):
            status = S.PRELIMINARY if k < 4 else S.CONFIRMED
            b.add(k, 10 + target, status, b.contact(k, target), _truth_xy(ds, k, target))


def test_perfect_tracker(dataset):
    b = Builder(dataset)
    perfect(dataset, b)
    m = run_metrics(dataset, b.outputs())
    assert m.target_contacts == 40
    assert (m.hits, m.losses, m.clutter_associated) == (38, 0, 0)
    assert m.hit_rate == 100.0
    assert (m.confirmed_tracks, m.false_tracks, m.track_breaks, m.lost_targets) == (2, 0, 0, 0)
    assert m.position_rmse_m == 0.0
    assert m.mean_time_to_confirm_s == pytest.approx(6.0)  # first contact scan 1, confirmed scan 4
    np.testing.assert_allclose(m.gospa[3:], 0.0, atol=1e-9)
    # before confirmation both targets are missed: sqrt(2 * c^2 / 2) = c
    np.testing.assert_allclose(m.gospa[:3], 1000.0)
    np.testing.assert_allclose(m.gospa_missed[:3], 1e6)


def test_false_track_and_clutter_in_a_target_track(dataset):
    b = Builder(dataset)
    perfect(dataset, b)
    for k in range(5, 12):  # a confirmed track of clutter contacts
        b.add(k, 99, S.PRELIMINARY if k < 7 else S.CONFIRMED, b.contact(k, -1))
    m = run_metrics(dataset, b.outputs())
    assert (m.confirmed_tracks, m.false_tracks) == (3, 1)
    assert m.series["false_tracks_per_scan"][6:11].tolist() == [1] * 5 and m.false_tracks_per_scan[:6].sum() == 0
    assert m.gospa_false[6] == pytest.approx(1000.0**2 / 2)
    # a target track that takes one clutter contact instead of its own
    b2 = Builder(dataset)
    perfect(dataset, b2)
    b2.rows[9] = [r if r[0] != 10 else (10, S.CONFIRMED, r[2], b2.contact(9, -1) - b2.bounds[8])
                  for r in b2.rows[9]]
    m2 = run_metrics(dataset, b2.outputs())
    assert (m2.hits, m2.losses, m2.clutter_associated) == (37, 1, 1)
    assert m2.hit_rate == pytest.approx(100 * 37 / 39)


def test_track_break_and_lost_target(dataset):
    b = Builder(dataset)
    for k in range(2, 21):  # target B tracked throughout
        b.add(k, 11, S.PRELIMINARY if k < 4 else S.CONFIRMED, b.contact(k, 1))
    for k in range(2, 9):  # target A: first track deleted at scan 8 after misses
        status = S.PRELIMINARY if k < 4 else S.CONFIRMED
        b.add(k, 10, S.DELETED if k == 8 else status, b.contact(k, 0) if k < 5 else None,
              _truth_xy(dataset, k, 0))
    for k in range(12, 21):  # re-initiated later
        b.add(k, 12, S.PRELIMINARY if k < 14 else S.CONFIRMED, b.contact(k, 0))
    m = run_metrics(dataset, b.outputs())
    assert (m.confirmed_tracks, m.track_breaks, m.lost_targets, m.false_tracks) == (3, 1, 1, 0)
    # A: hits scans 2-4 and 12-20 (12), losses scans 5-11 (7); B: 19 hits
    assert (m.hits, m.losses) == (31, 7)


def test_one_output_per_scan_is_required(dataset):
    with pytest.raises(OutputError, match="one output per scan"):
        run_metrics(dataset, Builder(dataset).outputs()[:-1])
