"""The neural-association tracker: selection rule, one scorer call per scan, tracking, bad input."""

from __future__ import annotations

import hashlib
import itertools
import json

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.data.sensor import cart_to_polar
from nnda.errors import ConfigError, TrackingError
from nnda.models.features import KINEMATIC, candidate_pairs, pair_features
from nnda.models.innovation import IMM_INNOVATION
from nnda.models.mlp import MLPWeights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, save_model, score_log_odds
from nnda.study.metrics import run_metrics
from nnda.tracking.assignment import greedy_matching
from nnda.tracking.gating import gate_tracks
from nnda.tracking.neural import NeuralTracker
from nnda.tracking.neural_matching import (
    RULES,
    first_stage,
    global_matching,
    reacquire,
    reacquired,
    rest_stage,
    served_matching,
)
from nnda.tracking.output import CONFIRMED, PRELIMINARY, TrackStatus
from nnda.tracking.registry import make_tracker


def sequential_greedy(rows, cols, score) -> list[tuple[int, int]]:
    """The rule written as a loop: best pair first (ties: lower row, then column), both sides free."""
    taken_rows, taken_cols, kept = set(), set(), []
    for i in sorted(range(len(rows)), key=lambda i: (-score[i], rows[i], cols[i])):
        if rows[i] not in taken_rows and cols[i] not in taken_cols:
            taken_rows.add(rows[i])
            taken_cols.add(cols[i])
            kept.append((int(rows[i]), int(cols[i])))
    return sorted(kept)


@pytest.mark.parametrize("seed", range(30))
def test_greedy_matching_is_the_sequential_rule(seed):
    rng = np.random.default_rng(seed)
    P = int(rng.integers(0, 40))
    rows, cols = rng.integers(0, 6, P), rng.integers(0, 8, P)
    score = rng.integers(-3, 4, P) / 3.0  # many ties
    r, c = greedy_matching(rows, cols, score)
    assert list(zip(r.tolist(), c.tolist())) == sequential_greedy(rows, cols, score)


def test_conflict_goes_to_the_higher_score_and_the_loser_falls_back():
    # tracks 0 and 1 both want contact 5; track 1 scores it higher, track 0 falls back to contact 6
    r, c = greedy_matching(np.array([0, 0, 1, 2]), np.array([5, 6, 5, 6]), np.array([0.9, 0.4, 0.95, 0.3]))
    assert (r.tolist(), c.tolist()) == ([0, 1], [6, 5])


def total_cost(rows, cols, pairs: dict, threshold: float, n_rows: int) -> float:
    """Cost of an assignment under the global rule: -log-odds of each chosen pair, the threshold's per miss."""
    chosen = [float(-score_log_odds(pairs[r, c])) for r, c in zip(rows, cols)]
    return sum(chosen) + (n_rows - len(chosen)) * float(-score_log_odds(threshold))


def brute_force_cost(pairs: dict, threshold: float, n_rows: int) -> float:
    """Least total cost over every assignment: each row takes one of its candidates or misses, columns distinct."""
    options = [[None] + [c for (r, c) in pairs if r == row] for row in range(n_rows)]
    best = np.inf
    for pick in itertools.product(*options):
        taken = [c for c in pick if c is not None]
        if len(set(taken)) == len(taken):
            rows = [r for r, c in enumerate(pick) if c is not None]
            best = min(best, total_cost(rows, taken, pairs, threshold, n_rows))
    return best


@pytest.mark.parametrize("seed", range(40))
def test_global_matching_has_the_least_total_cost_of_all_assignments(seed):
    rng = np.random.default_rng(seed)
    n_rows, n_cols = int(rng.integers(1, 5)), int(rng.integers(1, 6))
    cells = [(r, c) for r in range(n_rows) for c in range(n_cols) if rng.random() < 0.6]
    if seed % 4 == 0:  # some pairs saturated at +-1, as a tanh output is in floating point
        rng.shuffle(cells)
    pairs = {cell: float(rng.choice([-1.0, 1.0])) if seed % 4 == 0 and i < 2 else float(rng.uniform(-1, 1))
             for i, cell in enumerate(cells)}
    threshold = float(rng.uniform(-0.5, 0.5))
    rows, cols = (np.array(v, np.int64) for v in zip(*pairs)) if pairs else (np.empty(0, np.int64),) * 2
    r, c = global_matching(rows, cols, np.array(list(pairs.values())), threshold)
    assert len(set(r.tolist())) == r.size and len(set(c.tolist())) == c.size
    assert all((i, j) in pairs and pairs[i, j] > threshold for i, j in zip(r.tolist(), c.tolist()))
    got = total_cost(r.tolist(), c.tolist(), pairs, threshold, n_rows)
    assert got == pytest.approx(brute_force_cost(pairs, threshold, n_rows), rel=1e-9, abs=1e-9)


def test_global_matching_yields_the_greedy_first_pick_for_a_better_total():
    # track 0 scores contact 5 best (0.9) and contact 6 well (0.8); track 1 wants only contact 5 (0.85).
    # Greedy gives contact 5 to track 0 and leaves track 1 without; the global rule moves track 0 to
    # contact 6: log-odds 2.20 + 2.51 = 4.71 against 2.94 with a miss at log-odds 0
    rows, cols, score = np.array([0, 0, 1]), np.array([5, 6, 5]), np.array([0.9, 0.8, 0.85])
    r, c = greedy_matching(rows, cols, score)
    assert (r.tolist(), c.tolist()) == ([0], [5])
    r, c = global_matching(rows, cols, score, 0.0)
    assert sorted(zip(r.tolist(), c.tolist())) == [(0, 6), (1, 5)]
    # with no conflict, both rules take every pair
    r, c = global_matching(np.array([0, 1]), np.array([3, 2]), np.array([0.2, 0.7]), 0.0)
    assert sorted(zip(r.tolist(), c.tolist())) == [(0, 3), (1, 2)]


def test_global_matching_misses_when_the_threshold_is_above_every_score():
    rows, cols, score = np.array([0, 0, 1, 2]), np.array([0, 1, 0, 2]), np.array([0.9, 0.95, 0.97, 0.5])
    r, c = global_matching(rows, cols, score, 0.98)
    assert r.size == 0 and c.size == 0
    r, c = global_matching(rows, cols, score, 0.6)  # track 2's pair (0.5) is below it: track 2 misses
    assert sorted(zip(r.tolist(), c.tolist())) == [(0, 1), (1, 0)]
    r, c = global_matching(rows[:0], cols[:0], score[:0], 0.0)
    assert r.size == 0 and c.size == 0


def test_score_log_odds_reads_scores_as_probabilities():
    np.testing.assert_allclose(score_log_odds(np.array([0.0, 0.6, -0.6])), [0.0, np.log(4.0), -np.log(4.0)],
                               rtol=1e-9, atol=1e-12)
    saturated = score_log_odds(np.array([1.0, -1.0]))  # finite: clipped inside (-1, 1)
    assert np.isfinite(saturated).all() and saturated[0] == -saturated[1] > 25.0


class Recording(NeuralTracker):
    """A neural tracker that counts scorer calls and keeps what each scan's association saw and chose."""

    def __init__(self, sensor, config):
        super().__init__(sensor, config)
        self.calls = 0
        self.seen = []
        self.loaded = self.scorer

        def counted(features):
            self.calls += 1
            return self.loaded(features)
        self.scorer = counted

    def associate(self, tracks, pred, scan):
        assoc = super().associate(tracks, pred, scan)
        self.seen.append((tracks, scan.z.copy(), scan.xy.copy(), scan.time, assoc.contact.copy()))
        return assoc


MISS = float(-score_log_odds(0.0))  # a track's miss under the global rule at the default threshold


def least_cost_total(t, c, s, stage) -> float:
    """Least total cost of the global rule for the tracks of mask ``stage`` over gated pairs (t, c, s), by a dense
    assignment with a miss column per track (scipy's linear_sum_assignment: not the tracker's sparse solver)."""
    tracks, contacts = np.flatnonzero(stage), np.unique(c)
    cost = np.full((tracks.size, contacts.size + tracks.size), 1e6)
    cost[np.searchsorted(tracks, t), np.searchsorted(contacts, c)] = -score_log_odds(s)
    cost[:, contacts.size:][np.eye(tracks.size, dtype=bool)] = MISS
    r, k = linear_sum_assignment(cost)
    return float(cost[r, k].sum())


@pytest.mark.parametrize("association", ["greedy", "global"])
@pytest.mark.parametrize("confirmed_first", [False, True])
def test_one_scorer_call_per_scan_and_choices_follow_the_rule(model_file, confirmed_first, association):
    ds = generate(PRESETS["S1"], seed=0)
    config = NeuralTracker.config_type(model=model_file, confirmed_first=confirmed_first, association=association)
    tracker = Recording(ds.scenario.sensor, config)
    for scan in ds.scans():
        tracker.step(scan)
    assert 0 < tracker.calls <= len(tracker.seen) <= ds.n_scans
    conflicts = 0
    for tracks, z, xy, time, contact in tracker.seen:
        expected = np.full(len(tracks), -1)
        t, c = candidate_pairs(tracks.p2, tracks.t2, tracks.az2, xy, z[:, 1], time)
        if t.size:
            s = tracker.loaded(pair_features(tracks.p1[t], tracks.t1[t], tracks.p2[t], tracks.t2[t], xy[c], time))
            ok = s > 0
            conflicts += np.unique(c[ok]).size < ok.sum()
            if association == "global":  # each stage's choice has the least total cost
                score = dict(zip(zip(t[ok].tolist(), c[ok].tolist()), s[ok].tolist()))
                chosen = np.flatnonzero(contact >= 0)
                assert all((i, contact[i]) in score for i in chosen)  # gated pairs above the threshold only
                assert np.unique(contact[chosen]).size == chosen.size
                confirmed = tracks.status == TrackStatus.CONFIRMED
                taken = np.zeros(len(z), bool)
                for stage in [confirmed, ~confirmed] if confirmed_first else [np.ones(len(tracks), bool)]:
                    mine = chosen[stage[chosen]]
                    got = sum(-score_log_odds(score[i, contact[i]]) for i in mine) + (stage.sum() - mine.size) * MISS
                    free = ok & stage[t] & ~taken[c]
                    assert got == pytest.approx(least_cost_total(t[free], c[free], s[free], stage), rel=1e-9)
                    taken[contact[mine]] = True
                continue
            rank = s + 2.0 * (tracks.status[t] == TrackStatus.CONFIRMED) if confirmed_first else s
            for i, j in sequential_greedy(t[ok], c[ok], rank[ok]):
                expected[i] = j
        np.testing.assert_array_equal(contact, expected)
    assert conflicts > 0  # the run did exercise the conflict rule


def _scan_delays_and_nees(ds, outputs):
    """Per target, scans from its first contact to its first confirmed track; and the normalised
    position errors e^T P^-1 e of confirmed, updated tracks against their own target's truth."""
    det, truth, bounds = ds.detections, ds.truth, ds.scan_bounds()
    votes: dict[int, list[int]] = {}
    for o in outputs:
        for i in np.flatnonzero(o.contact >= 0):
            votes.setdefault(int(o.track_id[i]), []).append(int(det.target_id[bounds[o.scan - 1] + o.contact[i]]))
    owner = {t: max(set(v), key=v.count) for t, v in votes.items()}
    first_confirmed, nees = {}, []
    for o in outputs:
        for i in np.flatnonzero((o.status == TrackStatus.CONFIRMED) & (o.contact >= 0)):
            target = owner[int(o.track_id[i])]
            if target < 0:
                continue
            first_confirmed.setdefault(target, o.scan)
            rows = np.flatnonzero((truth.scan == o.scan) & (truth.target_id == target))
            if rows.size == 0:  # the target's trajectory has ended: the track updates on clutter
                continue
            row = rows[0]
            e = np.array([o.state[i, 0] - truth.x[row], o.state[i, 2] - truth.y[row]])
            nees.append(e @ np.linalg.solve(o.covariance[i][np.ix_([0, 2], [0, 2])], e))
    first_contact = {t: int(det.scan[det.target_id == t].min()) for t in range(len(ds.scenario.targets))}
    delays = {t: first_confirmed.get(t, 10**6) - first_contact[t] for t in first_contact}
    return delays, np.array(nees)


@pytest.mark.parametrize("preset", ["S1", "S2"])
def test_targets_confirmed_quickly_with_consistent_errors(model_file, preset):
    ds = generate(PRESETS[preset], seed=0)
    tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(model_file), "lifecycle": {"confirmation": "mn"}})
    outputs = [tracker.step(scan) for scan in ds.scans()]
    delays, nees = _scan_delays_and_nees(ds, outputs)
    # the thesis's M/N rule: initiator, preliminary track, then M = 3 detections: 4 scans at the earliest; in S2 the
    # pair T5/T7 starts 280 m apart and their preliminary tracks compete for a few scans
    assert all(d >= 4 for d in delays.values()), delays
    if preset == "S1":
        assert all(d <= 6 for d in delays.values()), delays
    else:  # every target confirmed, on average as fast as the other trackers must (8 scans)
        assert max(delays.values()) < 10**6 and np.mean(list(delays.values())) <= 8, delays
    # 2-D normalised errors: median 1.39 and 99 % below 9.21 if the covariance is right
    assert 0.7 < np.median(nees) < 2.5 and np.mean(nees < 9.21) > 0.9
    m = run_metrics(ds, outputs)
    # S2: ~83 % with the spec's three features (the thesis reports 93 %), from track breaks
    assert m.false_tracks == 0 and m.hit_rate > (90.0 if preset == "S1" else 80.0)


def band_model(path, max_speed_change: float = 150.0, max_turn_rate: float = 30.0):
    """A hand-set 3-5-1 scorer: positive when |ΔV| < max_speed_change m/s and |Δα| < max_turn_rate deg/s.

    Hidden units 0-3 are soft steps at the four band edges (+1 inside), the output is
    tanh(5 (sum - 3)): about +1 inside the band, -1 outside. It makes the association
    certain where targets move plausibly, so the tracker's own logic is under test.
    """
    a, b = 0.1, 0.5
    w1 = np.array([[a, 0, 0], [-a, 0, 0], [0, b, 0], [0, -b, 0], [0, 0, 0]])
    b1 = np.array([a * max_speed_change] * 2 + [b * max_turn_rate] * 2 + [0.0])
    weights = MLPWeights(w1, b1, np.array([5.0, 5.0, 5.0, 5.0, 0.0]), -15.0)
    return save_model(Scorer(weights, Normaliser(np.zeros(3), np.ones(3))), path)


def test_band_model_scores_as_designed(tmp_path):
    from nnda.models.scorer import load_model
    scorer = load_model(band_model(tmp_path / "band.json"))
    s = scorer(np.array([[0.0, 0.0, 2.0], [100.0, -20.0, 4.0], [200.0, 0.0, 2.0], [0.0, 45.0, 2.0]]))
    assert (s[:2] > 0.99).all() and (s[2:] < -0.99).all()


def test_no_clutter_full_detection_one_track_per_target(tmp_path, model_file):
    sc = PRESETS["S6"].model_copy(update={"clutter": Clutter(law="none")})
    ds = generate(sc, seed=1)
    n = len(sc.targets)
    band = make_tracker("nn", ds.scenario.sensor, {"model": str(band_model(tmp_path / "band.json"))})
    m = run_metrics(ds, [band.step(scan) for scan in ds.scans()])
    assert (m.confirmed_tracks, m.false_tracks, m.track_breaks, m.lost_targets) == (n, 0, 0, 0)
    assert m.clutter_associated == 0 and m.hit_rate > 97.0
    # the trained scorer makes no false track either, and finds every target (it may drop and
    # restart a track: the features cap its accuracy near 94 %, as Vargas Avila (2015) reports)
    trained = make_tracker("nn", ds.scenario.sensor, {"model": str(model_file)})
    m = run_metrics(ds, [trained.step(scan) for scan in ds.scans()])
    assert m.false_tracks == 0 and m.confirmed_tracks - m.track_breaks == n


def test_crossing_targets_keep_their_tracks(model_file):
    # two targets crossing at right angles at the same point at t = 80 s (scan 40), light clutter
    a = Target(name="east", x_m=-15_000.0, y_m=14_000.0, heading_deg=90.0, speed_m_s=150.0,
               segments=[Segment(duration_s=160.0)])
    b = Target(name="north", x_m=-3_000.0, y_m=2_000.0, heading_deg=0.0, speed_m_s=150.0,
               segments=[Segment(duration_s=160.0)])
    ds = generate(Scenario(name="crossing", duration_s=160.0, targets=[a, b], clutter=Clutter(count=20)), seed=2)
    tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(model_file)})
    outputs = [tracker.step(scan) for scan in ds.scans()]
    bounds, tid = ds.scan_bounds(), ds.detections.target_id
    # which confirmed track used each target's contact, scan by scan, from 10 scans before to 10 after
    users = {0: [], 1: []}
    for o in outputs[29:50]:
        for i in np.flatnonzero((o.status == TrackStatus.CONFIRMED) & (o.contact >= 0)):
            target = tid[bounds[o.scan - 1] + o.contact[i]]
            if target >= 0:
                users[int(target)].append(int(o.track_id[i]))
    follower = {}
    for target, ids in users.items():
        values, counts = np.unique(ids, return_counts=True)
        assert counts.max() >= 19, (target, ids)  # one track follows it through the crossing ...
        follower[target] = values[counts.argmax()]
    assert follower[0] != follower[1]  # ... and not the same one


@pytest.mark.parametrize("seed", range(20))
def test_reacquire_is_the_nearest_free_pick_of_the_waiting_tracks(seed):
    rng = np.random.default_rng(seed)
    P = int(rng.integers(0, 30))
    rows, cols, d2 = rng.integers(0, 5, P), rng.integers(0, 7, P), rng.integers(0, 15, P).astype(float)
    waiting, taken = rng.random(5) < 0.6, rng.random(7) < 0.3
    r, c = reacquire(rows, cols, d2, waiting, taken, 9.21)
    eligible = [i for i in range(P) if waiting[rows[i]] and not taken[cols[i]] and d2[i] <= 9.21]
    expected = sequential_greedy(rows[eligible], cols[eligible], -d2[eligible])
    assert list(zip(r.tolist(), c.tolist())) == expected
    left = [i for i in eligible if rows[i] not in r and cols[i] not in c]
    assert not left  # no pair a waiting track could still take


def test_the_stages_on_a_hand_made_scan():
    C, P = CONFIRMED, PRELIMINARY  # plain ints, as the tracker passes them (an IntEnum compiles the kernels again)
    status, consecutive = np.array([C, C, P, C], np.int8), np.array([0, 1, 0, 2])
    track, cand, score = np.array([0, 1, 1, 2, 2]), np.array([0, 1, 2, 0, 3]), np.array([0.9, 0.8, 0.7, 0.95, 0.6])
    g_rows, g_cols, g_d2 = np.array([0, 1, 3]), np.array([0, 2, 3]), np.array([1.0, 2.0, 5.0])
    kept_track, kept_cand, _, first, (done, rows, cols, _, _) = first_stage(
        track, cand, score, status, consecutive, 4, True, True, 0, RULES["served"], 0.0, g_rows, g_cols, g_d2)
    # track 1 missed last scan: its pair with contact 1 lies outside its gate and goes; track 2 picks later
    assert list(zip(kept_track.tolist(), kept_cand.tolist())) == [(0, 0), (1, 2), (2, 0), (2, 3)]
    assert first.tolist() == [True, True, False, False]
    # track 3 has no network pair: the served assignment gives it contact 3 of its gate
    assert done and dict(zip(rows.tolist(), cols.tolist())) == {0: 0, 1: 2, 3: 3}
    contact = np.full(4, -1)
    contact[rows] = cols
    done, rows, cols, _, _ = rest_stage(contact, first, kept_track, kept_cand, score[[0, 2, 3, 4]], 4,
                                        RULES["served"], 0.0)
    assert done and rows.size == 0  # track 2's contacts went to the confirmed tracks
    # without the served pick, track 3 re-acquires contact 3; track 0 (a contact last scan) is then lost
    again, lost = reacquired(np.array([-1, 2, -1, -1]), status, consecutive, C, 0, g_rows, g_cols, g_d2, 9.21, 4)
    assert again.tolist() == [0, 2, -1, 3] and lost.size == 0
    again, lost = reacquired(np.array([-1, 2, -1, -1]), status, consecutive, C, 0, g_rows, g_cols, g_d2, 0.5, 4)
    assert again.tolist() == [-1, 2, -1, -1] and lost.tolist() == [0]
    # the preliminary track 2 left without a pick (preliminary_gate) takes its free contact, not a taken one
    p_rows, p_cols, p_d2 = np.array([2, 2]), np.array([0, 1]), np.array([1.0, 3.0])
    again, _ = reacquired(np.array([0, 2, -1, 3]), status, consecutive, P, 0, p_rows, p_cols, p_d2, 13.82, 4)
    assert again.tolist() == [0, 2, 1, 3]


class RecordingPredictions(Recording):
    """A `Recording` that keeps each scan's tracks, prediction, checked scan and chosen contacts."""

    def associate(self, tracks, pred, scan):
        assoc = NeuralTracker.associate(self, tracks, pred, scan)
        self.seen.append((tracks, pred, scan, assoc.contact.copy()))
        return assoc


def test_confirmed_tracks_pick_and_reacquire_before_the_preliminary_ones(model_file):
    ds = generate(PRESETS["S2"], seed=0)
    gate = 9.21
    config = NeuralTracker.config_type(model=model_file, confirmed_first=True, coast_gate=gate, coast_after=0)
    tracker = RecordingPredictions(ds.scenario.sensor, config)
    for scan in ds.scans():
        tracker.step(scan)
    contested = 0  # scans where a re-acquired contact was also a preliminary track's pick above the threshold
    for tracks, pred, scan, contact in tracker.seen:
        z, xy = scan.z, scan.xy
        t, c = candidate_pairs(tracks.p2, tracks.t2, tracks.az2, xy, z[:, 1], scan.time)
        s = tracker.loaded(pair_features(tracks.p1[t], tracks.t1[t], tracks.p2[t], tracks.t2[t], xy[c], scan.time))
        confirmed = tracks.status == TrackStatus.CONFIRMED
        expected = np.full(len(tracks), -1)
        first = (s > 0) & confirmed[t]
        for i, j in sequential_greedy(t[first], c[first], s[first]):
            expected[i] = j
        _, g = gate_tracks(scan.filter, pred, z, xy, gate)
        free = confirmed[g.rows] & (expected[g.rows] == -1) & (g.d2 <= gate) & ~np.isin(g.cols, expected)
        reacquired = sequential_greedy(g.rows[free], g.cols[free], -g.d2[free])
        for i, j in reacquired:
            expected[i] = j
        rest = (s > 0) & ~confirmed[t] & ~np.isin(c, expected)
        contested += bool(np.isin([j for _, j in reacquired], c[(s > 0) & ~confirmed[t]]).any())
        for i, j in sequential_greedy(t[rest], c[rest], s[rest]):
            expected[i] = j
        np.testing.assert_array_equal(contact, expected)
    assert contested > 0  # the order mattered in some scan (S2 seed 0: two)


def _picks_outside_the_gate_after_a_miss(model_file, ds, gate_after_miss: bool) -> tuple[int, int]:
    """(picks of confirmed tracks that missed their last scan, those outside the IMM gate) over a run."""
    gate = 9.21
    config = NeuralTracker.config_type(model=model_file, coast_gate=gate, gate_after_miss=gate_after_miss,
                                       lifecycle={"confirmation": "mn"})  # coasting as M/N counts it
    tracker = RecordingPredictions(ds.scenario.sensor, config)
    for scan in ds.scans():
        tracker.step(scan)
    picks = outside = 0
    for tracks, pred, scan, contact in tracker.seen:
        mine = np.flatnonzero((tracks.status == TrackStatus.CONFIRMED) & (tracks.consecutive >= 1) & (contact >= 0))
        _, g = gate_tracks(scan.filter, pred, scan.z, scan.xy, gate)
        inside = set(zip(g.rows.tolist(), g.cols.tolist()))
        picks += mine.size
        outside += sum((int(i), int(contact[i])) not in inside for i in mine)
    return picks, outside


def test_gate_after_miss_keeps_a_coasting_tracks_picks_inside_the_imm_gate(model_file):
    ds = generate(PRESETS["S3"], seed=0)  # detection gaps
    picks, outside = _picks_outside_the_gate_after_a_miss(model_file, ds, True)
    assert picks > 0 and outside == 0
    assert _picks_outside_the_gate_after_a_miss(model_file, ds, False)[1] > 0  # the network alone does pick there


def _preliminary_tracks_left_near_a_free_contact(model_file, ds, preliminary_gate: float | None) -> tuple[int, int]:
    """(picks of preliminary tracks, preliminary tracks left without a contact while a free one lay in their
    IMM gate of 13.82) over a run."""
    gate = 13.82
    config = NeuralTracker.config_type(model=model_file, preliminary_gate=preliminary_gate,
                                       lifecycle={"confirmation": "score"})
    tracker = RecordingPredictions(ds.scenario.sensor, config)
    for scan in ds.scans():
        tracker.step(scan)
    picks = left = 0
    for tracks, pred, scan, contact in tracker.seen:
        preliminary = tracks.status == TrackStatus.PRELIMINARY
        picks += int((preliminary & (contact >= 0)).sum())
        _, g = gate_tracks(scan.filter, pred, scan.z, scan.xy, gate)
        free = np.ones(len(scan.z), bool)
        free[contact[contact >= 0]] = False
        waiting = preliminary & (contact < 0)
        left += np.unique(g.rows[waiting[g.rows] & free[g.cols]]).size
    return picks, left


def test_preliminary_gate_gives_a_refused_young_track_its_nearest_free_contact(model_file):
    ds = generate(PRESETS["S6"], seed=0)  # turning and accelerating targets
    picks, left = _preliminary_tracks_left_near_a_free_contact(model_file, ds, 13.82)
    assert picks > 0 and left == 0
    with_network_alone = _preliminary_tracks_left_near_a_free_contact(model_file, ds, None)
    assert with_network_alone[1] > 0 and with_network_alone[0] < picks


def gap_shy_model(path):
    """A hand-set 9-2-1 scorer on the IMM-extended features: about +1 for a pair one scan after the track's
    last contact (ΔT < 3 s) with d² < 9, about -1 otherwise: it never picks a track up after a miss."""
    w1 = np.zeros((2, IMM_INNOVATION.size))
    w1[0, IMM_INNOVATION.names.index("delta_t_s")] = -2.0
    w1[1, IMM_INNOVATION.names.index("mahalanobis_d2")] = -1.0
    weights = MLPWeights(w1, np.array([6.0, 9.0]), np.array([5.0, 5.0]), -5.0)
    scorer = Scorer(weights, Normaliser(np.zeros(IMM_INNOVATION.size), np.ones(IMM_INNOVATION.size)),
                    IMM_INNOVATION)
    return save_model(scorer, path)


def test_coast_gate_picks_a_track_up_after_a_gap_the_network_refuses(tmp_path):
    target = Target(name="gap", x_m=-10_000.0, y_m=15_000.0, heading_deg=90.0, speed_m_s=150.0,
                    missed_scans=[20, 21, 22], segments=[Segment(duration_s=100.0)])
    ds = generate(Scenario(name="gap", duration_s=100.0, targets=[target], clutter=Clutter(count=10)), seed=4)
    model = str(gap_shy_model(tmp_path / "gap-shy.json"))
    m = {}
    for gate in (None, 9.21):
        tracker = make_tracker("nn", ds.scenario.sensor, {"model": model, "coast_gate": gate})
        m[gate] = run_metrics(ds, [tracker.step(scan) for scan in ds.scans()])
    assert m[None].lost_targets == 1 and m[None].track_breaks == 1  # deleted at scan 23, started again
    assert (m[9.21].lost_targets, m[9.21].track_breaks, m[9.21].false_tracks) == (0, 0, 0)
    assert m[9.21].hits > m[None].hits


def test_bad_coast_gate_is_refused(model_file):
    for field in ("gate_after_miss", "retrodiction"):
        with pytest.raises(ConfigError, match=rf"invalid nn config[\s\S]*{field} needs coast_gate"):
            make_tracker("nn", Sensor(), {"model": str(model_file), field: True})
    with pytest.raises(ConfigError, match=r"invalid nn config[\s\S]*'served' needs coast_gate"):
        make_tracker("nn", Sensor(), {"model": str(model_file), "coast_gate": 9.21, "association": "served"})
    with pytest.raises(ConfigError, match=r"invalid nn config[\s\S]*coast_gate"):
        make_tracker("nn", Sensor(), {"model": str(model_file), "coast_gate": 0.0})
    with pytest.raises(ConfigError, match=r"invalid nn config[\s\S]*coast_after"):
        make_tracker("nn", Sensor(), {"model": str(model_file), "coast_gate": 9.21, "coast_after": -1})


def test_bad_scans_are_refused(model_file):
    tracker = make_tracker("nn", Sensor(), {"model": str(model_file)})
    tracker.step(Scan(1, 2.0, np.empty((0, 2))))  # an empty scan is fine
    tracker.step(Scan(2, 4.0, np.array([[10_000.0, 1.0], [12_000.0, 2.0]])))
    with pytest.raises(TrackingError, match="does not come after"):
        tracker.step(Scan(3, 4.0, np.array([[10_000.0, 1.0]])))
    with pytest.raises(TrackingError, match="contact 1 is invalid"):
        tracker.step(Scan(3, 6.0, np.array([[10_000.0, 1.0], [np.nan, 0.5]])))
    with pytest.raises(TrackingError, match=r"shape \(N, 2\)"):
        tracker.step(Scan(3, 6.0, np.ones((3, 3))))


def test_model_of_another_feature_version_is_refused(model_file, tmp_path):
    doc = json.loads(model_file.read_text())
    doc["feature_version"] = KINEMATIC.version + 1
    other = tmp_path / "model.json"
    other.write_text(json.dumps(doc))
    with pytest.raises(ConfigError, match=r"field 'model': .*feature.*version"):
        make_tracker("nn", Sensor(), {"model": str(other)})
    with pytest.raises(ConfigError, match=r"field 'model': .*no such model file"):
        make_tracker("nn", Sensor(), {"model": str(tmp_path / "missing.json")})


@pytest.mark.parametrize("params, field", [
    ({}, "model"), ({"threshold": 1.0}, "threshold"), ({"threshold": -1.5}, "threshold"),
    ({"association": "optimal"}, "association"), ({"association": 1}, "association")])
def test_bad_config_is_refused(params, field, model_file):
    params = {"model": str(model_file), **params} if field != "model" else params
    with pytest.raises(ConfigError, match=rf"invalid nn config[\s\S]*(: | - ){field}\b"):
        make_tracker("nn", Sensor(), params)


def test_directory_holding_a_model_is_accepted_and_same_data_gives_same_output(model_file):
    ds = generate(PRESETS["S4"], seed=5)
    runs = []
    for where in (model_file, model_file.parent):
        tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(where)})
        runs.append([tracker.step(scan) for scan in ds.scans()])
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a.track_id, b.track_id)
        np.testing.assert_array_equal(a.state, b.state)


def test_a_model_of_the_other_feature_set_is_refused(model_file, ext_model_file):
    sensor = PRESETS["S1"].sensor
    with pytest.raises(ConfigError, match="trained on feature set 'imm-innovation-9', but this tracker is "
                                          "configured for 'kinematic-3'"):
        make_tracker("nn", sensor, {"model": str(ext_model_file), "feature_set": "kinematic-3"})
    with pytest.raises(ConfigError, match="trained on feature set 'kinematic-3', but this tracker is "
                                          "configured for 'imm-innovation-9'"):
        make_tracker("nn", sensor, {"model": str(model_file), "feature_set": "imm-innovation-9"})
    with pytest.raises(ConfigError, match="feature_set"):
        make_tracker("nn", sensor, {"model": str(model_file), "feature_set": "polar-2"})
    assert make_tracker("nn", sensor, {"model": str(ext_model_file), "feature_set": "imm-innovation-9"})


@pytest.mark.parametrize("preset", ["S1", "S2"])
def test_extended_features_lose_fewer_contacts_than_the_seed_features(model_file, ext_model_file, preset):
    ds = generate(PRESETS[preset], 0)
    m = {}
    for name, path in (("seed", model_file), ("ext", ext_model_file)):
        tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(path)})
        m[name] = run_metrics(ds, [tracker.step(scan) for scan in ds.scans()])
    assert m["ext"].false_tracks == 0
    assert m["ext"].losses < m["seed"].losses
    assert m["ext"].track_breaks <= m["seed"].track_breaks
    assert m["ext"].hit_rate > 90.0


def test_a_model_scoring_nan_is_an_error_not_silence(model_file):
    ds = generate(PRESETS["S1"], seed=3)
    tracker = NeuralTracker(ds.scenario.sensor, NeuralTracker.config_type(model=model_file))
    tracker.scorer = lambda features: np.full(len(features), np.nan)  # a broken model
    with pytest.raises(TrackingError, match=r"nn: scan \d+: the model .* scored \d+ of \d+ pairs as NaN"):
        for scan in ds.scans():
            tracker.step(scan)


def test_the_imm_feature_tracker_gives_the_same_bytes_for_the_same_seed(ext_model_file):
    """Same scenario and seed -> the same bits in every output, the compiled IMM cycle included."""
    def digest() -> str:
        ds = generate(PRESETS["S1"], seed=3)
        tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(ext_model_file)})
        h = hashlib.sha256()
        for out in map(tracker.step, ds.scans()):
            for a in (out.track_id, out.status, out.state, out.covariance, out.contact):
                h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()

    assert digest() == digest()


def _lured_run(model: str, retrodiction: bool, lure_scan: int = 12, n_scans: int = 20):
    """One target east at 150 m/s, y = 12 km, no clutter, but unseen at ``lure_scan``, where a lone contact
    250 m to its left passes for it (the band model accepts the bend). Returns the tracker's outputs."""
    tracker = make_tracker("nn", Sensor(), {"model": model, "coast_gate": 9.21, "retrodiction": retrodiction})
    outputs = []
    for k in range(1, n_scans + 1):
        x, y = -5_000.0 + 300.0 * k, 12_000.0 + (250.0 if k == lure_scan else 0.0)
        r, az = cart_to_polar(np.array([x]), np.array([y]))
        outputs.append(tracker.step(Scan(k, 2.0 * k, np.column_stack([r, az]))))
    return tracker, outputs


def test_retrodiction_puts_a_lured_track_back_on_its_target(tmp_path):
    model = str(band_model(tmp_path / "band.json"))
    lure = 12
    for retrodiction in (False, True):
        tracker, out = _lured_run(model, retrodiction, lure)
        before, lured, after = out[lure - 2], out[lure - 1], out[lure]
        assert before.status.tolist() == [TrackStatus.CONFIRMED] and lured.contact.tolist() == [0]  # it bit
        first = int(before.track_id[0])
        ids = after.track_id.tolist()
        if not retrodiction:  # the lured track misses the target; the target opens a new track
            assert after.contact[ids.index(first)] == -1
            continue
        # the track went back to its branch without the lure: the target's contact, one track throughout
        assert after.contact.tolist() == [0] and all(o.track_id.tolist() == [first] for o in out[lure:])
        tracker, _ = _lured_run(model, True, lure, n_scans=lure + 1)
        tracks = tracker.tracks  # the contact history skips the lure; its scan counts as a miss
        assert (tracks.t1[0], tracks.t2[0]) == (2.0 * (lure - 1), 2.0 * (lure + 1))
        assert tracks.p1[0, 1] == pytest.approx(12_000.0, abs=100) and tracks.misses[0] >= 1


def test_retrodiction_changes_nothing_without_a_lure(tmp_path):
    model = str(band_model(tmp_path / "band.json"))
    _, plain = _lured_run(model, False, lure_scan=0)
    _, retro = _lured_run(model, True, lure_scan=0)
    for a, b in zip(plain, retro):
        np.testing.assert_array_equal(a.contact, b.contact)
        np.testing.assert_array_equal(a.state, b.state)


def _ended_run(model: str, release: bool, end: int = 10, lure: int = 14):
    """One target east at 150 m/s, y = 12 km, no clutter, seen up to scan ``end`` and gone after; at scan
    ``lure`` (its track's fourth scan without a contact) a lone contact 1.2 km to the left of its path lies in
    the coasting track's gate, too far to be worth taking (the score rule deletes the track that takes it),
    and the next scan has a contact 300 m east of that one (a start at 150 m/s). Returns the outputs."""
    tracker = make_tracker("nn", Sensor(), {"model": model, "coast_gate": 9.21, "coast_after": 0,
                                            "release_on_deletion": release,
                                            "lifecycle": {"confirmation": "score", "false_deletion": 5e-4}})
    outputs = []
    for k in range(1, lure + 2):
        xy = [(-5_000.0 + 300.0 * k, 12_000.0)] if k <= end else []
        xy += [(-5_000.0 + 300.0 * lure + 300.0 * (k - lure), 13_200.0)] if k >= lure else []
        r, az = cart_to_polar(*np.array(xy).reshape(-1, 2).T)
        outputs.append(tracker.step(Scan(k, 2.0 * k, np.column_stack([r, az]))))
    return outputs


def test_release_on_deletion_gives_the_contact_of_a_deleted_track_back(tmp_path):
    model = str(band_model(tmp_path / "band.json"))
    lure = 14
    kept, released = _ended_run(model, False, lure=lure), _ended_run(model, True, lure=lure)
    for out in (kept, released):  # the same track up to the lure, which deletes it
        assert out[lure - 2].status.tolist() == [TrackStatus.CONFIRMED]
        assert out[lure - 1].track_id.tolist() == [0] and out[lure - 1].status.tolist() == [TrackStatus.DELETED]
    assert kept[lure - 1].contact.tolist() == [0] and kept[lure - 1].state[0, 2] > 13_000.0  # it took the lure
    assert len(kept[lure]) == 0  # the lure was used: the next contact only initiates
    # released: the track ends on a miss at its prediction, and the lure starts a track with the next contact
    assert released[lure - 1].contact.tolist() == [-1]
    assert released[lure - 1].state[0, 2] == pytest.approx(12_000.0, abs=50.0)
    assert released[lure - 1].state[0, 0] == pytest.approx(kept[lure - 1].state[0, 0], abs=50.0)
    assert released[lure].status.tolist() == [TrackStatus.PRELIMINARY] and released[lure].contact.tolist() == [0]
    for a, b in zip(kept[:lure - 1], released[:lure - 1]):  # nothing else changes
        np.testing.assert_array_equal(a.state, b.state)


def brute_force_served(pairs: dict, gate: dict, threshold: float, n_rows: int) -> tuple[int, float]:
    """(most pairs, then greatest total log-odds above the threshold's) over every one-to-one matching of
    the network pairs above the threshold and the gate pairs (worth 0 unless also a network pair)."""
    worth = {k: float(score_log_odds(v) - score_log_odds(threshold)) for k, v in pairs.items() if v > threshold}
    worth.update({k: 0.0 for k in gate if k not in worth})
    best = (0, 0.0)
    cols = sorted({c for _, c in worth})
    for choice in itertools.product([None, *cols], repeat=n_rows):
        picked = [(r, c) for r, c in enumerate(choice) if c is not None]
        if len({c for _, c in picked}) < len(picked) or any(p not in worth for p in picked):
            continue
        value = (len(picked), sum(worth[p] for p in picked))
        if value[0] > best[0] or (value[0] == best[0] and value[1] > best[1] + 1e-9):
            best = value
    return best


@pytest.mark.parametrize("seed", range(40))
def test_served_matching_serves_the_most_rows_then_the_greatest_log_odds(seed):
    rng = np.random.default_rng(seed)
    n_rows, n_cols = int(rng.integers(1, 5)), int(rng.integers(1, 5))
    pairs = {(int(r), int(c)): float(rng.uniform(-1, 1)) for r, c in rng.integers(0, [n_rows, n_cols], (6, 2))}
    gate = {(int(r), int(c)): float(rng.uniform(0, 9)) for r, c in rng.integers(0, [n_rows, n_cols], (4, 2))}
    threshold = float(rng.choice([0.0, 0.3]))
    rows, cols = np.array([k[0] for k in pairs], np.int64), np.array([k[1] for k in pairs], np.int64)
    g_rows, g_cols = np.array([k[0] for k in gate], np.int64), np.array([k[1] for k in gate], np.int64)
    r, c = served_matching(rows, cols, np.array(list(pairs.values())), threshold, g_rows, g_cols,
                           np.array(list(gate.values())))
    assert len(set(r.tolist())) == r.size and len(set(c.tolist())) == c.size
    worth = {k: float(score_log_odds(v) - score_log_odds(threshold)) for k, v in pairs.items() if v > threshold}
    assert all((i, j) in worth or (i, j) in gate for i, j in zip(r.tolist(), c.tolist()))
    got = (r.size, sum(worth.get((i, j), 0.0) for i, j in zip(r.tolist(), c.tolist())))
    want = brute_force_served(pairs, gate, threshold, n_rows)
    assert got[0] == want[0] and got[1] == pytest.approx(want[1], rel=1e-9, abs=1e-9)


def test_served_matching_yields_a_contact_to_the_track_that_has_no_other():
    # track 0 scores contact 1 a little above contact 0; track 1 (coasting) has contact 1 in its gate alone
    r, c = served_matching(np.array([0, 0]), np.array([0, 1]), np.array([0.83, 0.88]), 0.0,
                           np.array([1]), np.array([1]), np.array([6.6]))
    assert dict(zip(r.tolist(), c.tolist())) == {0: 0, 1: 1}
    r, c = served_matching(np.array([0, 0]), np.array([0, 1]), np.array([0.83, 0.88]), 0.0,
                           np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0))
    assert dict(zip(r.tolist(), c.tolist())) == {0: 1}  # alone, it takes its best
