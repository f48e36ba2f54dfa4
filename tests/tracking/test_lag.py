"""The fixed-lag output (nnda.tracking.lag): identity at lag 0, back-fill, RTS smoothing, MHT's decided
contacts, and what it buys on a scene with a confirmation delay."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import rts_smoother

import nnda
from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.errors import ConfigError
from nnda.filters.imm import IMM
from nnda.filters.motion import ConstantVelocity
from nnda.study.metrics import ScoredRun, run_metrics
from nnda.study.track import track_table
from nnda.tracking.lag import EndsAtScorePeak, FixedLag, LagMotion, RevisesBranches, stationary
from nnda.tracking.mht import MHTTracker
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY, TrackerOutput
from nnda.tracking.registry import make_tracker


class Replay:
    """A tracker that reports prepared outputs, one per step (``filter``: its motion model, if any)."""

    name = "replay"

    def __init__(self, outputs, track_filter=None):
        self.outputs = outputs
        if track_filter is not None:
            self.filter = track_filter
        self.reset()

    def reset(self):
        self.i = 0

    def step(self, scan):
        self.i += 1
        return self.outputs[self.i - 1]


def _scan(k: int) -> Scan:
    return Scan(k, 2.0 * k, np.empty((0, 2)), 0)


def _out(scan, ids, status, x=None, P=None, contact=None):
    k = len(ids)
    x = np.zeros((k, 4)) if x is None else np.asarray(x, float).reshape(k, 4)
    P = np.tile(np.eye(4), (k, 1, 1)) if P is None else np.asarray(P, float).reshape(k, 4, 4)
    contact = np.full(k, NO_CONTACT) if contact is None else np.asarray(contact)
    return TrackerOutput(scan, 2.0 * scan, np.asarray(ids, np.int64), np.asarray(status, np.int8), x, P,
                         np.asarray(contact, np.int64))


def _run(tracker, lag, n):
    return _stepped(tracker, lag, (_scan(k) for k in range(1, n + 1)))


def _stepped(tracker, lag, scans):
    """The online and the lagged outputs of ``tracker`` over ``scans`` with ``lag``, each one per scan."""
    fixed = FixedLag(tracker, lag)
    online, lagged = [], []
    for scan in scans:
        o, late = fixed.step(scan)
        online.append(o)
        if late is not None:
            lagged.append(late)
    return online, lagged + fixed.flush()


@pytest.fixture(scope="module")
def s3():
    """S3's first 50 scans: targets confirmed a few scans after their first contacts."""
    return generate(preset("S3").model_copy(update={"duration_s": 100.0}), 0, 0)


@pytest.mark.parametrize("kind", ["gnn", "mht"])
def test_lag_0_gives_exactly_the_online_outputs(s3, kind):
    tracker = make_tracker(kind, s3.scenario.sensors, {})
    fixed = FixedLag(tracker, 0)
    pairs = [fixed.step(scan) for scan in s3.scans()]
    assert all(late is online for online, late in pairs)
    assert fixed.flush() == []
    online = [o for o, _ in pairs]
    fresh = make_tracker(kind, s3.scenario.sensors, {})
    again = [fresh.step(scan) for scan in s3.scans()]
    a, b = track_table(s3, online), track_table(s3, again)
    assert a.equals(b)
    # and through the Python API: lag = 0 is the online table, byte for byte
    assert nnda.track(s3, "gnn", lag=0).equals(nnda.track(s3, "gnn"))


def test_the_api_returns_the_lagged_table_with_the_online_rows():
    ds = generate(preset("S1").model_copy(update={"duration_s": 80.0}), 0, 0)  # a target ends at 60 s
    online, lagged = nnda.track(ds, "jpda"), nnda.track(ds, "jpda", lag=2)
    assert lagged.schema == online.schema
    rows = lambda t: set(zip(t.column("scan").to_pylist(), t.column("track_id").to_pylist()))  # noqa: E731
    dropped = rows(online) - rows(lagged)
    assert rows(lagged) <= rows(online) and dropped  # the ended tracks' rows after their coasted tail's first
    ended = {i: k for k, i, s in zip(lagged.column("scan").to_pylist(), lagged.column("track_id").to_pylist(),
                                      lagged.column("status").to_pylist()) if s == "deleted"}
    assert all(i in ended and k > ended[i] for k, i in dropped)
    assert not lagged.select(["x", "y"]).equals(online.select(["x", "y"]))
    confirmed = [sum(s == "confirmed" for s in t.column("status").to_pylist()) for t in (online, lagged)]
    assert confirmed[1] > confirmed[0]  # back-filled


def _tail(contacts, deleted_at):
    """One confirmed track (id 7) with ``contacts`` per scan from scan 1 and DELETED at ``deleted_at``."""
    outs = [_out(k, [7], [CONFIRMED], contact=[c]) for k, c in enumerate(contacts, start=1)]
    return outs + [_out(deleted_at, [7], [DELETED])] if deleted_at else outs


@pytest.mark.parametrize("lag", [1, 3, 5])
def test_a_track_that_coasts_to_its_deletion_ends_where_its_contacts_end(lag):
    # contacts at scans 1-3, then coasting 4-6, deleted at 7: the lagged output reports it DELETED at the
    # first coasted scan the window sees the deletion from, and drops its later rows
    outs = _tail([0, 1, 2, NO_CONTACT, NO_CONTACT, NO_CONTACT], 7)
    online, lagged = _run(Replay(outs), lag, 7)
    assert [len(o) for o in online] == [1] * 7
    first = max(4, 7 - lag)  # the window of scan k - lag reaches the deletion at 7 from scan 7 - lag on
    status = {o.scan: int(o.status[0]) for o in lagged if len(o)}
    assert status == {**{k: CONFIRMED for k in range(1, first)}, first: DELETED}
    assert [len(o) for o in lagged] == [1] * first + [0] * (7 - first)


def test_a_track_that_coasts_through_a_gap_is_not_touched():
    outs = _tail([0, 1, NO_CONTACT, NO_CONTACT, NO_CONTACT, 5, NO_CONTACT], 8)
    _, lagged = _run(Replay(outs), 3, 8)
    assert [int(o.status[0]) for o in lagged[:7]] == [CONFIRMED] * 6 + [DELETED]
    assert len(lagged[7]) == 0


class Peaked(Replay):
    """A `Replay` that tells the score peaks (`EndsAtScorePeak`): ``peaks`` maps a track id to its peak's time."""

    def __init__(self, outputs, peaks):
        super().__init__(outputs)
        self.peaks = peaks
        self.asked = False  # whether a fixed-lag output asked for the peaks

    def keep_score_peaks(self):
        self.asked = True

    def score_peaks(self, reported):
        gone = reported.track_id[reported.status == DELETED]
        return gone, np.array([self.peaks[i] for i in gone.tolist()], float)


def test_a_track_deleted_in_the_window_ends_after_its_score_peak_contacts_or_not():
    # contacts at 1-3, 5 (clutter in its grown gate), coasting at 4 and 6, deleted at 7; its score peaked at
    # scan 3 (time 6 s): from scan 4 on, once the window sees the deletion, it is ended, where the coasting
    # rule waits for the contact-free tail (scan 6)
    outs = _tail([0, 1, 2, NO_CONTACT, 3, NO_CONTACT], 7)
    _, plain = _run(Replay(outs), 3, 7)
    tracker = Peaked(outs, {7: 6.0})
    _, peaked = _run(tracker, 3, 7)
    assert tracker.asked
    assert isinstance(Peaked([], {}), EndsAtScorePeak) and not isinstance(Replay([]), EndsAtScorePeak)
    assert [int(o.status[0]) if len(o) else None for o in plain] == [CONFIRMED] * 5 + [DELETED, None]
    assert [int(o.status[0]) if len(o) else None for o in peaked] == [CONFIRMED] * 3 + [DELETED] + [None] * 3
    # a peak at the last scan before the deletion (12 s, scan 6) ends nothing the coasting rule keeps
    _, late = _run(Peaked(outs, {7: 12.0}), 3, 7)
    for a, b in zip(plain, late):
        assert a.track_id.tolist() == b.track_id.tolist() and a.status.tolist() == b.status.tolist()


def test_score_peaks_end_only_confirmed_tracks_and_are_forgotten_on_reset():
    # track 8 preliminary at 1-3, deleted at 4 with a peak at 2 s: a preliminary report stays as it is
    outs = [_out(k, [8], [PRELIMINARY], contact=[0]) for k in (1, 2, 3)] + [_out(4, [8], [DELETED])]
    _, lagged = _run(Peaked(outs, {8: 2.0}), 3, 4)
    assert [o.status.tolist() for o in lagged] == [[PRELIMINARY]] * 3 + [[DELETED]]
    fixed = FixedLag(Peaked(_tail([0, 1], 3), {7: 2.0}), 3)
    for k in (1, 2, 3):
        fixed.step(_scan(k))
    assert fixed._peaks[0].tolist() == [7]
    fixed.reset()
    assert not fixed._peaks[0].size
    assert fixed.flush() == []


def test_ended_tracks_are_forgotten_on_reset():
    fixed = FixedLag(Replay(_tail([0, NO_CONTACT], 3)), 1)
    for k in (1, 2, 3):
        fixed.step(_scan(k))
    fixed.flush()
    fixed.reset()
    assert fixed.revise(_out(1, [7], [CONFIRMED], contact=[0])) is None
    assert len(fixed.revise(_out(2, [7], [CONFIRMED], contact=[0]))) == 1


def test_every_scan_gets_one_lagged_output_in_order():
    outs = [_out(k, [0], [PRELIMINARY]) for k in range(1, 6)]
    for lag in (1, 3, 7):
        online, lagged = _run(Replay(outs), lag, 5)
        assert [o.scan for o in lagged] == [1, 2, 3, 4, 5]


def test_a_confirmed_track_is_reported_confirmed_at_its_preliminary_scans_within_the_lag():
    # track 7: preliminary at scans 1-3, confirmed at 4; track 8 preliminary, deleted at 3, never confirmed
    outs = [_out(1, [7, 8], [PRELIMINARY, PRELIMINARY]), _out(2, [7, 8], [PRELIMINARY, PRELIMINARY]),
            _out(3, [7, 8], [PRELIMINARY, DELETED]), _out(4, [7], [CONFIRMED]), _out(5, [7], [CONFIRMED])]
    _, lag2 = _run(Replay(outs), 2, 5)
    status = {o.scan: dict(zip(o.track_id.tolist(), o.status.tolist())) for o in lag2}
    assert status[1] == {7: PRELIMINARY, 8: PRELIMINARY}  # confirmed at 4: more than 2 scans on
    assert status[2] == {7: CONFIRMED, 8: PRELIMINARY}
    assert status[3] == {7: CONFIRMED, 8: DELETED}
    assert status[4] == {7: CONFIRMED}
    _, lag3 = _run(Replay(outs), 3, 5)
    assert lag3[0].status.tolist() == [CONFIRMED, PRELIMINARY]
    # same ids, same order, same states (no motion model: no smoothing)
    for o, late in zip(outs, lag3):
        assert np.array_equal(o.track_id, late.track_id)
        assert np.array_equal(o.state, late.state)


def _cv_track(n: int, dt: float, rng):
    """A CV target measured in position and filtered by filterpy's Kalman filter with the CV model of
    `ConstantVelocity` (sigma_q 3.5): the filtered means and covariances, the F and Q of each step."""
    from filterpy.kalman import KalmanFilter

    cv = ConstantVelocity()
    F = np.eye(4)
    F[0, 1] = F[2, 3] = dt
    Q = cv.noise(np.array(dt))
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.F, kf.Q = F, Q
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    kf.R = np.eye(2) * 50.0**2
    kf.x = np.array([0.0, 100.0, 0.0, -50.0])
    kf.P = np.diag([1e4, 1e3, 1e4, 1e3])
    truth = np.array([0.0, 100.0, 0.0, -50.0])
    xs, Ps = [], []
    for _ in range(n):
        truth = F @ truth
        kf.predict()
        kf.update(truth[[0, 2]] + rng.normal(0, 50.0, 2))
        xs.append(kf.x.copy())
        Ps.append(kf.P.copy())
    return np.array(xs), np.array(Ps), F, Q


def test_the_smoothing_is_the_rts_smoother_over_the_lag_window():  # exact for one CV model
    n, lag, dt = 12, 3, 2.0
    xs, Ps, F, Q = _cv_track(n, dt, np.random.default_rng(4))
    outs = [_out(k + 1, [3], [CONFIRMED], xs[k], Ps[k], [0]) for k in range(n)]
    imm = IMM(models=(ConstantVelocity(),), tpm=((1.0,),), mu0=(1.0,))
    _, lagged = _run(Replay(outs, imm), lag, n)
    for k in range(n):
        end = min(k + lag, n - 1)
        ref_x, ref_P, _, _ = rts_smoother(xs[k:end + 1], Ps[k:end + 1], [F] * (end + 1 - k), [Q] * (end + 1 - k))
        np.testing.assert_allclose(lagged[k].state[0], ref_x[0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(lagged[k].covariance[0], ref_P[0], rtol=1e-9, atol=1e-9)
    # the smoothing did something: the lagged covariance is smaller than the filtered one
    assert np.trace(lagged[3].covariance[0]) < np.trace(Ps[3]) - 1.0


def test_a_track_deleted_in_the_window_keeps_its_filtered_states():
    xs, Ps, _, _ = _cv_track(4, 2.0, np.random.default_rng(1))
    statuses = [CONFIRMED, CONFIRMED, DELETED]
    outs = [_out(k + 1, [3], [statuses[k]], xs[k], Ps[k]) for k in range(3)] + [_out(4, [], [])]
    imm = IMM(models=(ConstantVelocity(),), tpm=((1.0,),), mu0=(1.0,))
    _, lagged = _run(Replay(outs, imm), 2, 4)
    np.testing.assert_array_equal(lagged[0].state[0], xs[0])
    np.testing.assert_array_equal(lagged[0].covariance[0], Ps[0])


def test_the_imm_motion_weights_the_models_noise_by_their_stationary_probabilities():
    tpm = np.array([[0.99, 0.01], [0.10, 0.90]])
    pi = stationary(tpm)
    np.testing.assert_allclose(pi @ tpm, pi, atol=1e-12)
    np.testing.assert_allclose(pi, [10 / 11, 1 / 11], atol=1e-12)
    tracker = make_tracker("gnn", preset("S1").sensors, {})
    motion = LagMotion.of(tracker)
    cv, ct = tracker.filter.models
    np.testing.assert_allclose(motion.basis, pi[0] * cv.noise_basis + pi[1] * ct.noise_basis[:, :4, :4])
    assert motion.turn_var == pytest.approx(pi[1] * ct.omega_var0)
    assert LagMotion.of(Replay([])) is None


def test_a_lag_out_of_range_is_refused_with_its_value():
    with pytest.raises(ConfigError, match=r"lag = -1: give a whole number of scans from 0"):
        FixedLag(Replay([]), -1)
    with pytest.raises(ConfigError, match=r"lag = 2.5"):
        FixedLag(Replay([]), 2.5)
    with pytest.raises(ConfigError, match=r"argument 'lag' is True"):
        nnda.track(generate(preset("S1"), 0, 0), "gnn", lag=True)


class Spied(MHTTracker):
    """MHT that writes down, every scan, the chosen leaves' families and contact histories."""

    def reset(self):
        super().reset()
        self.chosen_hist = []

    def _report(self, scan, time, leaves, shown, chosen):
        if leaves is None or not chosen.size:
            self.chosen_hist.append({})
        else:
            fam = leaves.tracks.track_id[chosen]
            self.chosen_hist.append(dict(zip(fam.tolist(), leaves.hist[chosen].tolist())))
        return super()._report(scan, time, leaves, shown, chosen)


@pytest.fixture(scope="module")
def crowded():
    """Two crossing targets in dense clutter, 30 scans: MHT's best branch changes its mind."""
    sc = preset("S3")
    sc = sc.model_copy(update={"duration_s": 60.0,
                               "sensors": [sc.sensors[0].model_copy(update={"clutter": sc.sensors[0].clutter.model_copy(
                                   update={"count": 400})})]})
    return generate(sc, 0, 0)


@pytest.mark.parametrize("lag", [2, 4])
def test_mht_lagged_contacts_are_those_of_the_current_best_branch(crowded, lag):
    tracker = Spied(crowded.scenario.sensors)
    assert isinstance(tracker, RevisesBranches)
    n_scan = tracker.config.n_scan
    online, lagged = _stepped(tracker, lag, crowded.scans())
    hist = tracker.chosen_hist
    n = len(online)
    changed = 0
    alive = [set(o.track_id[o.status != DELETED].tolist()) for o in online]
    for i, (o, late) in enumerate(zip(online, lagged)):
        for tid, c_online, c_late in zip(o.track_id.tolist(), o.contact.tolist(), late.contact.tolist()):
            # the branch chosen at the last scan up to i + lag at which the family is reported (not deleted),
            # read back to scan i; n_scan scans back the decision is final
            expected = c_online
            for at in range(min(i + lag, n - 1, i + n_scan - 1), i - 1, -1):
                if tid in alive[at]:
                    branch = hist[at][tid][n_scan - 1 - (at - i)]
                    expected = c_online if branch < NO_CONTACT else branch
                    break
            assert c_late == expected, (i, tid)
            changed += c_late != c_online
    assert changed > 0  # the scene makes the best branch revise some contacts


def test_the_lagged_output_covers_more_of_the_targets_on_a_scene_with_confirmation_delay(s3):
    online, lagged = _stepped(make_tracker("gnn", s3.scenario.sensors, {}), 3, s3.scans())
    a, b = run_metrics(s3, online), run_metrics(s3, lagged)
    # coverage: the share of target-scans a confirmed track is matched to (the CLEAR-MOT matching)
    coverage_online, coverage_lagged = (ScoredRun(s3, o).matches.scan.size / s3.truth.scan.size
                                        for o in (online, lagged))
    assert coverage_lagged > coverage_online
    assert b.values["gospa"] < a.values["gospa"]
    # the smoothing brings the estimates nearer the truth, and no smoothed covariance exceeds the filtered one
    assert b.values["position_rmse_m"] < 0.8 * a.values["position_rmse_m"]
    assert b.values["gospa_localisation"] < a.values["gospa_localisation"]
    gap = np.concatenate([o.covariance - late.covariance for o, late in zip(online, lagged)])
    assert np.linalg.eigvalsh(0.5 * (gap + gap.transpose(0, 2, 1))).min() > -1e-6 * np.abs(gap).max()
    assert b.values["mean_time_to_confirm_s"] < a.values["mean_time_to_confirm_s"]


@pytest.mark.slow  # about 3.5 s: the plots of the online tracks are written too
def test_nnda_track_writes_and_scores_the_lagged_output_beside_the_online_one(tmp_path):
    import json

    import pyarrow.parquet as pq
    from typer.testing import CliRunner

    from nnda.app.cli import app
    from nnda.data.dataset import write_dataset

    ds = generate(preset("S1").model_copy(update={"duration_s": 40.0}), 0, 0)
    write_dataset(ds, tmp_path / "ds")
    result = CliRunner().invoke(app, ["track", str(tmp_path / "ds"), "--tracker", "gnn", "--out",
                                      str(tmp_path / "t"), "--lag", "2", "--quiet"])
    assert result.exit_code == 0, result.output
    assert "tracks_lag2.parquet" in result.output
    online, lagged = pq.read_table(tmp_path / "t/tracks.parquet"), pq.read_table(tmp_path / "t/tracks_lag2.parquet")
    assert lagged.select(["scan", "track_id"]).equals(online.select(["scan", "track_id"]))
    assert not lagged.equals(online)
    scores = json.loads((tmp_path / "t/scores.json").read_text())
    assert scores["lagged"]["lag"] == 2 and set(scores["lagged"]["metrics"]) == set(scores["metrics"])
    assert scores["lagged"]["metrics"]["gospa"] < scores["metrics"]["gospa"]
    refused = CliRunner().invoke(app, ["track", str(tmp_path / "ds"), "--tracker", "gnn", "--out",
                                       str(tmp_path / "t2"), "--lag", "-1"])
    assert refused.exit_code == 2 and "--lag" in refused.output
