"""CLEAR-MOT (MOTA, MOTP, identity switches) and the position matching, against py-motmetrics and by hand."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Target
from nnda.study.matching import match_scans
from nnda.study.metrics import ScoredRun, run_metrics
from nnda.tracking.output import TrackerOutput
from nnda.tracking.output import TrackStatus as S

THRESHOLD = 400.0  # m: well above the noise below, so nearby targets compete for tracks


@pytest.fixture(scope="module")
def crossing():
    """Four targets on paths that cross and run side by side, one starting late, no process noise."""
    def target(name, x, y, heading, **kw):
        return Target(name=name, x_m=x, y_m=y, heading_deg=heading, speed_m_s=120.0, **kw)
    targets = [target("a", -9_000.0, 12_000.0, 90.0, segments=[Segment(duration_s=120.0)]),
               target("b", -3_000.0, 6_500.0, 0.0, segments=[Segment(duration_s=120.0)]),
               target("c", -9_000.0, 12_300.0, 90.0, segments=[Segment(duration_s=60.0, normal_accel=3.0)]),
               target("d", -2_700.0, 6_500.0, 0.0, start_time_s=20.0, segments=[Segment(duration_s=100.0)])]
    sc = Scenario(name="mot", duration_s=120.0, targets=targets, clutter=Clutter(law="none"),
                  process_noise=ProcessNoise(model="none"))
    return generate(sc, seed=2)


def synthetic_outputs(ds, seed):
    """Tracks that follow the targets with noise, drop out, jump to other targets, plus false tracks."""
    rng = np.random.default_rng(seed)
    t = ds.truth
    n_targets = len(ds.scenario.targets)
    follows = {100 + i: i for i in range(n_targets)}  # track id -> target it follows
    next_id = 200
    rows = {k: [] for k in range(1, ds.n_scans + 1)}
    for k in range(1, ds.n_scans + 1):
        here = {int(g): (t.x[i], t.y[i]) for i, g in zip(np.flatnonzero(t.scan == k), t.target_id[t.scan == k])}
        if rng.random() < 0.08:  # a track jumps to another target (an identity switch)
            tid = int(rng.choice(list(follows)))
            follows[tid] = int(rng.integers(n_targets))
        if rng.random() < 0.05:  # a track is replaced by a new one on the same target
            tid = int(rng.choice(list(follows)))
            follows[next_id] = follows.pop(tid)
            next_id += 1
        for tid, g in follows.items():
            if g not in here or rng.random() < 0.1:  # target absent, or the track misses this scan
                continue
            x, y = here[g]
            sigma = 150.0 if rng.random() < 0.1 else 40.0
            status = S.CONFIRMED if rng.random() > 0.05 else S.PRELIMINARY
            rows[k].append((tid, status, x + rng.normal(0, sigma), y + rng.normal(0, sigma)))
        for j in range(rng.poisson(0.7)):  # false tracks near a random target, some inside the threshold
            g = int(rng.choice(list(here))) if here else 0
            x, y = here.get(g, (0.0, 10_000.0))
            rows[k].append((900 + j, S.CONFIRMED, x + rng.normal(0, 500.0), y + rng.normal(0, 500.0)))
    outputs = []
    for k in range(1, ds.n_scans + 1):
        r = rows[k]
        state = np.array([[x, 0.0, y, 0.0] for _, _, x, y in r]).reshape(-1, 4)
        outputs.append(TrackerOutput(k, 2.0 * k, np.array([q[0] for q in r], np.int64),
                                     np.array([q[1] for q in r], np.int8), state, np.zeros((len(r), 4, 4)),
                                     np.full(len(r), -1, np.int64)))
    return outputs


def motmetrics_summary(ds, outputs, threshold):
    mm = pytest.importorskip("motmetrics")
    acc = mm.MOTAccumulator(auto_id=True)
    t = ds.truth
    for k, o in enumerate(outputs, start=1):
        here = t.scan == k
        conf = o.status == S.CONFIRMED
        truth_xy = np.column_stack([t.x[here], t.y[here]])
        est_xy = o.state[conf][:, [0, 2]]
        d = np.sqrt(((truth_xy[:, None, :] - est_xy[None, :, :]) ** 2).sum(axis=-1))
        d[d >= threshold] = np.nan
        acc.update(t.target_id[here].tolist(), o.track_id[conf].tolist(), d)
    mh = mm.metrics.create()
    return mh.compute(acc, metrics=["mota", "motp", "num_switches"], name="run").iloc[0]


@pytest.mark.parametrize("seed", range(12))
def test_clear_mot_equals_py_motmetrics(crossing, seed):
    outputs = synthetic_outputs(crossing, seed)
    ours = run_metrics(crossing, outputs, cutoff_m=THRESHOLD)
    theirs = motmetrics_summary(crossing, outputs, THRESHOLD)
    assert ours.ownership == "position"
    assert ours.id_switches == int(theirs["num_switches"])
    assert ours.mota == pytest.approx(float(theirs["mota"]), rel=1e-9)
    assert ours.motp_m == pytest.approx(float(theirs["motp"]), rel=1e-9)


def test_the_synthetic_runs_exercise_switches_and_competition(crossing):
    """The oracle comparison is only worth something if the inputs hold switches and contested tracks."""
    runs = [ScoredRun(crossing, synthetic_outputs(crossing, seed), THRESHOLD) for seed in range(12)]
    assert sum(int(r.matches.switch.sum()) for r in runs) >= 12
    near_two = 0
    for r in runs:  # confirmed tracks within the threshold of two targets at once
        t = crossing.truth
        for k in range(1, crossing.n_scans + 1):
            tr = np.column_stack([t.x[t.scan == k], t.y[t.scan == k]])
            est = np.column_stack([r.x, r.y])[(r.scan == k) & r.confirmed]
            d = np.sqrt(((tr[:, None] - est[None]) ** 2).sum(-1))
            near_two += int(((d < THRESHOLD).sum(axis=0) >= 2).sum())
    assert near_two >= 50


def test_matching_by_hand():
    """Scan 1: t0-k0, t1-k1; scan 2: k1 jumps to t0 while k0 vanishes (one switch for t0);
    scan 3: k0 returns beside t0, but t0 keeps its last track k1 (no switch); t1 is missed."""
    truth_scan = np.array([1, 1, 2, 2, 3, 3])
    truth_target = np.array([0, 1, 0, 1, 0, 1])
    truth_xy = np.array([[0, 0], [1000, 0], [0, 0], [1000, 0], [0, 0], [1000, 0]], float)
    track_scan = np.array([1, 1, 2, 3, 3])
    track = np.array([0, 1, 1, 0, 1])
    track_xy = np.array([[10, 0], [1000, 20], [5, 0], [1, 0], [30, 0]], float)
    m = match_scans(truth_scan, truth_target, truth_xy, track_scan, track, track_xy, 3, 2, 2, 100.0)
    assert m.scan.tolist() == [1, 1, 2, 3]
    assert m.target.tolist() == [0, 1, 0, 0]
    assert m.track.tolist() == [0, 1, 1, 1]
    assert m.switch.tolist() == [False, False, True, False]
    np.testing.assert_allclose(m.distance, [10.0, 20.0, 5.0, 30.0])


def test_matching_prefers_more_pairs_to_a_shorter_total():
    """Targets at 0 and 90 m, tracks at 1 m and -90 m, threshold 100 m: the pair (t0, k0) of 1 m alone
    would leave t1 unmatched (GOSPA's capped costs would take it: 1 + 100 < 90 + 89); the two pairs
    (t0, k1) of 90 m and (t1, k0) of 89 m win."""
    truth_xy = np.array([[0.0, 0.0], [90.0, 0.0]])
    track_xy = np.array([[1.0, 0.0], [-90.0, 0.0]])
    m = match_scans(np.array([1, 1]), np.array([0, 1]), truth_xy, np.array([1, 1]), np.array([0, 1]), track_xy,
                    1, 2, 2, 100.0)
    assert list(zip(m.target.tolist(), m.track.tolist())) == [(0, 1), (1, 0)]
    np.testing.assert_allclose(m.distance, [90.0, 89.0])


def test_a_pair_at_the_threshold_is_no_match():
    m = match_scans(np.array([1]), np.array([0]), np.array([[0.0, 0.0]]), np.array([1]), np.array([0]),
                    np.array([[100.0, 0.0]]), 1, 1, 1, 100.0)
    assert m.scan.size == 0


def test_the_close_pair_matching_equals_the_dense_one(monkeypatch):
    """Scans of hundreds of targets are matched over the pairs closer than the threshold only: the same matches,
    distances and identity switches as over the whole distance matrix (continuous positions: no ties)."""
    import nnda.study.matching as module

    rng = np.random.default_rng(4)
    n, scans = 300, 6
    start = rng.uniform(-50e3, 50e3, (n, 2))
    truth_scan = np.repeat(np.arange(1, scans + 1), n)
    truth_target = np.tile(np.arange(n), scans)
    truth_xy = np.concatenate([start + 100.0 * k for k in range(scans)])
    # tracks: a noisy copy of each target whose index is shuffled every other scan (switches), plus far ones
    track_scan, track, track_xy = [], [], []
    for k in range(scans):
        ids = rng.permutation(n) if k % 2 else np.arange(n)
        track_scan.append(np.full(n + 20, k + 1))
        track.append(np.concatenate([ids, n + np.arange(20)]))
        track_xy.append(np.concatenate([truth_xy[k * n:(k + 1) * n] + rng.normal(0, 300, (n, 2)),
                                        rng.uniform(-50e3, 50e3, (20, 2))]))
    args = (truth_scan, truth_target, truth_xy, np.concatenate(track_scan), np.concatenate(track),
            np.concatenate(track_xy), scans, n, n + 20, 1_000.0)
    monkeypatch.setattr(module, "DENSE_MAX_PAIRS", 0)
    close = match_scans(*args)
    monkeypatch.setattr(module, "DENSE_MAX_PAIRS", np.inf)
    dense = match_scans(*args)
    assert close.switch.sum() > 0 and close.target.size > n * scans // 2
    for name in ("scan", "target", "track", "switch"):
        np.testing.assert_array_equal(getattr(close, name), getattr(dense, name), err_msg=name)
    np.testing.assert_allclose(close.distance, dense.distance, rtol=1e-9)
