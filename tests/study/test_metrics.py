"""Run metrics on hand-made tracker outputs with known answers: ownership by contacts and by position,
agreement of the two on a tracker run, bad outputs."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Target
from nnda.study.metrics import ScoredRun, ScoringError, run_metrics
from nnda.tracking.output import TrackerOutput
from nnda.tracking.output import TrackStatus as S
from nnda.tracking.registry import make_tracker


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
    with pytest.raises(ScoringError, match="one output per scan"):
        run_metrics(dataset, Builder(dataset).outputs()[:-1])


OFFSET = (30.0, 40.0)  # m: target A's track sits 50 m off the truth


def layout(ds, with_contacts: bool) -> Builder:
    """A followed 50 m off (track 10); B by track 11 (deleted at scan 10), then track 12 from scan 12
    (a break); track 99, confirmed at scans 7-11, far from both targets (a false track)."""
    b = Builder(ds)

    def add(k, track, status, target):
        x, y = _truth_xy(ds, k, target)
        if track == 10:
            x, y = x + OFFSET[0], y + OFFSET[1]
        b.add(k, track, status, b.contact(k, target) if with_contacts else None, (x, y))

    for k in range(2, 21):
        add(k, 10, S.PRELIMINARY if k < 4 else S.CONFIRMED, 0)
    for k in range(2, 11):
        add(k, 11, S.DELETED if k == 10 else S.PRELIMINARY if k < 4 else S.CONFIRMED, 1)
    for k in range(12, 21):
        add(k, 12, S.PRELIMINARY if k < 14 else S.CONFIRMED, 1)
    for k in range(5, 12):
        row = b.contact(k, -1) if with_contacts else None
        b.add(k, 99, S.PRELIMINARY if k < 7 else S.CONFIRMED, row, (-30_000.0, -30_000.0))
    return b


def test_ownership_by_position_on_outputs_without_contacts(dataset):
    m = run_metrics(dataset, layout(dataset, with_contacts=False).outputs())
    assert m.ownership == "position"
    assert (m.confirmed_tracks, m.false_tracks, m.track_breaks, m.lost_targets) == (4, 1, 1, 1)
    # A matched at scans 4-20 (17, 50 m off), B at 4-9 and 14-20 (13, exact)
    assert m.position_rmse_m == pytest.approx(math.sqrt(17 * 50.0**2 / 30), rel=1e-12)
    assert m.series["false_tracks_per_scan"][6:11].tolist() == [1] * 5
    assert m.motp_m == pytest.approx(17 * 50.0 / 30, rel=1e-12)
    # 40 target-scans, 30 matched: 10 misses; track 99 is 5 false positives; B's track change is a switch
    assert m.id_switches == 1
    assert m.mota == pytest.approx(1 - (10 + 5 + 1) / 40, rel=1e-12)
    # the measures that count contacts are undefined without contacts
    assert m.hits is m.losses is m.clutter_associated is m.hit_rate is None
    assert m.target_contacts == 40


def test_both_kinds_agree_on_the_same_tracks(dataset):
    by_contacts = run_metrics(dataset, layout(dataset, with_contacts=True).outputs())
    by_position = run_metrics(dataset, layout(dataset, with_contacts=True).outputs(), ownership="position")
    assert (by_contacts.ownership, by_position.ownership) == ("contacts", "position")
    for key in ("confirmed_tracks", "false_tracks", "track_breaks", "lost_targets", "mota", "id_switches"):
        assert by_contacts.values[key] == by_position.values[key], key
    assert by_contacts.position_rmse_m == pytest.approx(by_position.position_rmse_m, rel=1e-12)
    # hits and losses by position: a track never confirmed has no owner, so the initiator contacts
    # before confirmation are outside the counted span; every used target contact is still a hit
    assert by_position.hits == by_contacts.hits


def test_contacts_are_required_for_ownership_by_contacts(dataset):
    outputs = layout(dataset, with_contacts=False).outputs()
    with pytest.raises(ScoringError, match="ownership by contacts: the outputs report no contacts"):
        run_metrics(dataset, outputs, ownership="contacts")
    with pytest.raises(ScoringError, match="ownership must be one of auto, contacts, position"):
        run_metrics(dataset, outputs, ownership="nearest")


@pytest.fixture(scope="module")
def gnn_run():
    ds = generate(PRESETS["S2"], seed=5)
    tracker = make_tracker("gnn", ds.scenario.sensor)
    return ds, [tracker.step(scan) for scan in ds.scans()]


def test_ownership_by_position_agrees_with_contacts_on_a_tracker_run(gnn_run):
    ds, outputs = gnn_run
    a, b = ScoredRun(ds, outputs), ScoredRun(ds, outputs, ownership="position")
    assert (a.ownership, b.ownership) == ("contacts", "position")
    shown = a.ever_confirmed
    assert shown.sum() >= len(ds.scenario.targets)
    assert (a.owner[shown] == b.owner[shown]).mean() >= 0.9
    ma, mb = run_metrics(ds, outputs), run_metrics(ds, outputs, ownership="position")
    for key in ("confirmed_tracks", "false_tracks", "track_breaks", "lost_targets"):
        assert abs(ma.values[key] - mb.values[key]) <= 1, key
    assert mb.position_rmse_m == pytest.approx(ma.position_rmse_m, rel=0.05)
    assert mb.hit_rate == pytest.approx(ma.hit_rate, abs=2.0)
    for key in ("gospa", "ospa", "mota", "motp_m", "id_switches"):  # ownership plays no part in these
        assert ma.values[key] == mb.values[key], key


def _output(k, n=1, **change):
    fields = dict(scan=k, time=2.0 * k, track_id=np.arange(n, dtype=np.int64), status=np.full(n, S.CONFIRMED, np.int8),
                  state=np.zeros((n, 4)) + [1e4, 0, 1e4, 0], covariance=np.zeros((n, 4, 4)),
                  contact=np.full(n, -1, np.int64))
    fields.update(change)
    return TrackerOutput(**fields)


@pytest.mark.parametrize("k, change, message", [
    (3, {"scan": 4}, r"output 2 \(scan 4\): expected scan 3"),
    (5, {"state": np.zeros((2, 4))}, r"scan 5\): state has shape \(2, 4\), expected \(1, 4\)"),
    (5, {"status": np.zeros(3, np.int8)}, r"scan 5\): status has shape \(3,\)"),
    (6, {"state": np.array([[np.nan, 0.0, 1.0, 0.0]])}, r"scan 6\): track 0 has a non-finite state"),
    (7, {"track_id": np.array([4, 4]), "status": np.full(2, S.CONFIRMED, np.int8), "state": np.zeros((2, 4)),
         "contact": np.full(2, -1)}, r"scan 7\): a track id appears more than once"),
    (8, {"contact": np.array([10_000])}, r"scan 8\): track 0 names contact 10000, but the scan has \d+ contacts"),
])
def test_bad_outputs_are_refused_naming_the_scan(dataset, k, change, message):
    outputs = [_output(i) for i in range(1, dataset.n_scans + 1)]
    outputs[k - 1] = _output(k, **change)
    with pytest.raises(ScoringError, match=message):
        run_metrics(dataset, outputs)


def test_the_count_error_counts_reported_tracks_against_targets_present():
    from nnda.data.generator import generate
    from nnda.data.presets import PRESETS
    from nnda.tracking.registry import make_tracker

    ds = generate(PRESETS["S1"], seed=3)
    tracker = make_tracker("gnn", ds.scenario.sensors)
    outs = [tracker.step(scan) for scan in ds.scans()]
    m = run_metrics(ds, outs)
    present = np.bincount(ds.truth.scan - 1, minlength=ds.n_scans)
    reported = np.array([int((o.status == 2).sum()) for o in outs])
    np.testing.assert_array_equal(m.count_error, np.abs(reported - present))
    assert m.count_error[-10:].max() <= 1  # every target followed at the end of S1


def test_time_to_a_correct_count_and_tracking_while_undetected_against_plain_loops():
    """Both measures of the harbour's questions, recomputed scan by scan from their definitions."""
    from nnda.study.matching import match_scans  # noqa: F401  (the matching the measure reads)
    from nnda.study.measures import SETTLED_SCANS

    harbour = PRESETS["harbour"].model_copy(update={"duration_s": 60.0})
    ds = generate(harbour, seed=1)
    for name in ("fusion-aa", "gnn"):
        tracker = make_tracker(name, ds.scenario.sensors)
        outs = [tracker.step(scan) for scan in ds.scans()]
        run = ScoredRun(ds, outs, ownership="position")
        m = run_metrics(ds, outs, ownership="position")
        present = np.bincount(ds.truth.scan, minlength=ds.n_scans + 1)[1:]
        reported = [int((o.status == S.CONFIRMED).sum()) for o in outs]
        first = next((k for k in range(ds.n_scans - SETTLED_SCANS + 1)
                      if all(reported[j] == present[j] for j in range(k, k + SETTLED_SCANS))), None)
        expect = math.nan if first is None else ds.scan_time[first] - ds.scan_time[0]
        assert m.time_to_count_s == pytest.approx(expect, nan_ok=True)
        matched = {(int(s), int(t)) for s, t in zip(run.matches.scan, run.matches.target)}
        t = ds.truth
        gaps = [(int(s), int(i)) for s, i, d in zip(t.scan, t.target_id, t.detected) if not d]
        assert m.tracked_undetected == pytest.approx(100.0 * sum(g in matched for g in gaps) / len(gaps))
