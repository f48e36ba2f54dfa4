"""Behaviour every model-free tracker must show (the neural tracker has its own tests), and the protocol
every registered tracker meets.

The contact trackers (`ContactTracker`s: GNN, JPDA, MHT) are scored by the contacts their tracks used
(`nnda.study.metrics.run_metrics`); the PHD trackers associate no contact, so the same scenes score them by
position (ownership "position": each scan's tracks matched to the true positions, as the study does)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import BoundWarning, ConfigError, TrackingError
from nnda.filters.imm import IMM
from nnda.filters.measurement import PolarMeasurement
from nnda.filters.motion import ConstantVelocity
from nnda.study.metrics import run_metrics
from nnda.tracking.gnn import _stage_pairs
from nnda.tracking.output import NO_CONTACT, TrackStatus
from nnda.tracking.protocol import Tracker, TrackerConfig
from nnda.tracking.registry import PEERS, TRACKERS, make_tracker
from nnda.tracking.tracker import ContactTracker
from nnda.tracking.tracks import Tracks, branched_moved, branching_args

MODEL_FREE = [name for name in TRACKERS if name != "nn"]
#: trackers whose tracks are built from contacts (scored by the contacts they used)
CONTACT = [name for name in MODEL_FREE if issubclass(TRACKERS[name], ContactTracker)]
#: trackers that report positions without contacts (the PHD family), scored by position
#: trackers set up for the harbour's ships of Lima (2022) (`nnda.tracking.phd.fusion`): the protocol tests here,
#: their quality in test_phd_fusion.py, not the aircraft scenes'
HARBOUR = [name for name in MODEL_FREE if TRACKERS[name].__module__ == "nnda.tracking.phd.fusion"]
POSITION = [name for name in MODEL_FREE if name not in CONTACT and name not in HARBOUR]


def run(name, dataset, params=None):
    tracker = make_tracker(name, dataset.scenario.sensor, params)
    return tracker, [tracker.step(scan) for scan in dataset.scans()]


def crossing() -> Scenario:
    """Two targets crossing at right angles at the same point and time, 80 scans, in the
    training scenes' dense clutter (0.36 per km^2, where M/N 3/4 lets some false tracks through)."""
    a = Target(name="east", x_m=-15_000.0, y_m=14_000.0, heading_deg=90.0, speed_m_s=150.0,
               segments=[Segment(duration_s=160.0)])
    b = Target(name="north", x_m=-3_000.0, y_m=2_000.0, heading_deg=0.0, speed_m_s=150.0,
               segments=[Segment(duration_s=160.0)])
    return Scenario(name="crossing", duration_s=160.0, targets=[a, b], clutter=Clutter(count=100))


@pytest.mark.parametrize("name", CONTACT)
@pytest.mark.parametrize("preset", ["S1", "S2"])
def test_follows_every_target_of_s1_and_s2(name, preset):
    ds = generate(PRESETS[preset], seed=3)
    _, outs = run(name, ds)
    m = run_metrics(ds, outs)
    n = len(ds.scenario.targets)
    assert m.confirmed_tracks - m.false_tracks >= n
    assert m.false_tracks <= 1 and m.lost_targets == 0
    assert m.hit_rate > 93.0  # the spec's reported range is 93-99.6 %
    assert m.mean_time_to_confirm_s <= 4 * 2.0 * 2  # within a few scans of the first contact
    assert m.position_rmse_m < 80.0  # measurement noise is 30 m x up to 70 m cross-range


@pytest.mark.parametrize("name", CONTACT)
def test_no_clutter_full_detection_one_track_per_target(name):
    sc = PRESETS["S6"].model_copy(update={"clutter": Clutter(law="none")})
    ds = generate(sc, seed=1)
    _, outs = run(name, ds)
    m = run_metrics(ds, outs)
    assert (m.confirmed_tracks, m.false_tracks, m.track_breaks, m.lost_targets) == (6, 0, 0, 0)
    assert m.clutter_associated == 0 and m.hit_rate > 97.0


@pytest.mark.parametrize("name", CONTACT)
def test_crossing_targets_keep_their_identity(name):
    ds = generate(crossing(), seed=2)
    _, outs = run(name, ds)
    m = run_metrics(ds, outs)
    assert m.track_breaks == 0 and m.lost_targets == 0
    assert m.hits >= 0.9 * m.target_contacts and m.clutter_associated <= 3


def gappy() -> Scenario:
    """One target turning after a minute, with two three-scan detection gaps, in clutter."""
    t = Target(name="gappy", x_m=-12_000.0, y_m=-8_000.0, heading_deg=45.0, speed_m_s=120.0,
               segments=[Segment(duration_s=60.0), Segment(duration_s=60.0, normal_accel=4.0)],
               missed_scans=[20, 21, 22, 40, 41, 42])
    return Scenario(name="gap", duration_s=120.0, targets=[t])


@pytest.mark.parametrize("name", CONTACT)
def test_keeps_a_target_through_a_three_scan_gap(name):
    ds = generate(gappy(), seed=4)
    _, outs = run(name, ds)
    m = run_metrics(ds, outs)
    assert m.lost_targets == 0 and m.track_breaks == 0


@pytest.mark.parametrize("name", MODEL_FREE)
def test_bad_scans_are_refused(name):
    tracker = make_tracker(name, Sensor())
    tracker.step(Scan(1, 2.0, np.empty((0, 2))))  # an empty scan is fine
    with pytest.raises(TrackingError, match="does not come after"):
        tracker.step(Scan(2, 2.0, np.array([[10_000.0, 1.0]])))
    with pytest.raises(TrackingError, match="contact 1 is invalid"):
        tracker.step(Scan(2, 4.0, np.array([[10_000.0, 1.0], [np.nan, 0.5]])))
    with pytest.raises(TrackingError, match=r"shape \(N, 2\)"):
        tracker.step(Scan(2, 4.0, np.ones((3, 3))))


@pytest.mark.parametrize("name", MODEL_FREE)
def test_same_data_same_output(name):
    ds = generate(PRESETS["S4"], seed=5)
    _, a = run(name, ds)
    _, b = run(name, ds)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.track_id, y.track_id)
        np.testing.assert_array_equal(x.state, y.state)


@pytest.mark.parametrize("name", POSITION)
@pytest.mark.parametrize("preset", ["S1", "S2"])
def test_position_trackers_follow_every_target_of_s1_and_s2(name, preset):
    ds = generate(PRESETS[preset], seed=3)
    _, outs = run(name, ds)
    m = run_metrics(ds, outs, ownership="position")
    assert m.mota >= 0.88  # misses (mostly the first scans of each target), false reports and switches
    assert m.false_tracks_per_scan.sum() <= 0.15 * len(outs)  # clutter near a target briefly makes a second report
    # breaks: a run's handful (the CPHD averaged 0.35 on S1 and 0.7 on S2 over 20 runs, 3 in this one)
    assert m.track_breaks <= 3 and m.count_error.mean() < 0.3
    assert m.position_rmse_m < 80.0  # measurement noise is 30 m x up to 70 m cross-range


@pytest.mark.parametrize("name", POSITION)
def test_position_trackers_without_clutter_one_track_per_target(name):
    sc = PRESETS["S6"].model_copy(update={"clutter": Clutter(law="none")})
    ds = generate(sc, seed=1)
    _, outs = run(name, ds)
    m = run_metrics(ds, outs, ownership="position")
    assert (m.track_breaks, m.id_switches, m.false_tracks) == (0, 0, 0) and m.mota >= 0.92
    n_true = np.bincount(ds.truth.scan, minlength=ds.n_scans + 1)
    # from the fifth scan one report per target (a label extracted after 3 sweeps in a row, the radar preset's
    # extraction_scans; the CPHD may keep the last target one scan after it ends)
    assert sum(len(o) != n_true[o.scan] for o in outs[4:]) <= 1


@pytest.mark.parametrize("name", POSITION)
def test_position_trackers_keep_crossing_targets_and_gaps(name):
    """Crossing targets: the tracks stay on their targets; a target through two three-scan gaps keeps its
    label (a PHD reports nothing during a gap: its weight falls below the extraction threshold)."""
    ds = generate(crossing(), seed=2)
    m = run_metrics(ds, run(name, ds)[1], ownership="position")
    assert m.track_breaks <= 1 and m.id_switches == 0 and m.mota >= 0.85
    ds = generate(gappy(), seed=4)
    m = run_metrics(ds, run(name, ds)[1], ownership="position")
    assert (m.track_breaks, m.id_switches) == (0, 0) and m.position_rmse_m < 80.0


@pytest.mark.parametrize("name", POSITION)
def test_the_measurement_model_is_a_component(name):
    """A PHD tracker given the radar's measurement model explicitly runs as by default; another changes it."""
    ds = generate(PRESETS["S3"], seed=2)
    cls, sensor = TRACKERS[name], ds.scenario.sensor
    default = np.concatenate([o.state for o in run(name, ds)[1]])
    explicit = cls(sensor, measurement=PolarMeasurement.from_sensor(sensor))
    np.testing.assert_array_equal(default, np.concatenate([explicit.step(s).state for s in ds.scans()]))
    wider = cls(sensor, measurement=PolarMeasurement(60.0, 6e-3))
    assert not np.array_equal(default, np.concatenate([wider.step(s).state for s in ds.scans()]))


def test_deleted_tracks_are_reported_once():
    ds = generate(PRESETS["S2"], seed=1)
    _, outs = run("gnn", ds)
    deleted = np.concatenate([o.track_id[o.status == TrackStatus.DELETED] for o in outs])
    assert deleted.size > 0 and np.unique(deleted).size == deleted.size
    for k, o in enumerate(outs[1:], 1):
        assert not np.isin(o.track_id, outs[k - 1].track_id[outs[k - 1].status == TrackStatus.DELETED]).any()


def test_unknown_tracker_and_bad_config():
    with pytest.raises(ConfigError, match="unknown tracker 'kalman'"):
        make_tracker("kalman", Sensor())
    with pytest.raises(ConfigError, match="gate"):
        make_tracker("gnn", Sensor(), {"gate": -1})
    with pytest.raises(ConfigError, match="lifecycle: .*m <= n"):
        make_tracker("mht", Sensor(), {"lifecycle": {"m": 9}})


def test_gnn_greedy_fallback_agrees_on_easy_scans():
    """Beyond max_exact_pairs GNN matches greedily; on well separated targets both agree."""
    ds = generate(PRESETS["S4"], seed=2)
    _, exact = run("gnn", ds)
    tracker, greedy = run("gnn", ds, {"max_exact_pairs": 0})
    assert tracker.n_greedy > 0
    a, b = run_metrics(ds, exact), run_metrics(ds, greedy)
    assert abs(a.hits - b.hits) <= 3 and b.lost_targets == 0


@pytest.mark.parametrize("name, params", [*((name, {}) for name in [*TRACKERS, *PEERS]),
                                          ("nn", {"association": "global"})])
def test_every_registered_tracker_meets_the_protocol(name, params, model_file):
    if name in PEERS:
        pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")
    tracker = make_tracker(name, Sensor(), {"model": str(model_file), **params} if name == "nn" else None)
    assert isinstance(tracker, Tracker) and tracker.name == name
    assert issubclass(tracker.config_type, TrackerConfig) and isinstance(tracker.config, tracker.config_type)
    short = crossing().model_copy(update={"duration_s": 40.0, "clutter": Clutter(count=20)})  # cheap for peers
    ds = generate(short, seed=1)
    outs = [tracker.step(scan) for scan in ds.scans()]
    tracker.reset()
    again = [tracker.step(scan) for scan in ds.scans()]  # reset forgets the run: the same output again
    for o, p in zip(outs, again):
        k = len(o)
        assert (o.track_id.shape, o.status.shape, o.state.shape, o.covariance.shape, o.contact.shape) == (
            (k,), (k,), (k, 4), (k, 4, 4), (k,))
        np.testing.assert_array_equal(o.track_id, p.track_id)
        np.testing.assert_array_equal(o.contact, p.contact)


@pytest.mark.parametrize("name", CONTACT)
def test_the_per_track_filter_is_a_component(name):
    """A tracker given the default filter explicitly runs as by default; another filter changes it."""
    ds = generate(PRESETS["S3"], seed=2)
    cls, sensor = TRACKERS[name], ds.scenario.sensor
    default = [o.state for o in run(name, ds)[1]]
    explicit = cls(sensor, track_filter=IMM.for_sensor(sensor))
    np.testing.assert_array_equal(np.concatenate(default), np.concatenate([explicit.step(s).state for s in ds.scans()]))
    cv_only = IMM(models=(ConstantVelocity(),), measurement=PolarMeasurement.from_sensor(sensor), tpm=((1.0,),),
                  mu0=(1.0,))
    tracker = cls(sensor, track_filter=cv_only)
    outs = [tracker.step(s) for s in ds.scans()]
    assert tracker.filter is cv_only
    assert run_metrics(ds, outs).confirmed_tracks >= 1
    assert not np.array_equal(np.concatenate(default), np.concatenate([o.state for o in outs]))


@pytest.mark.parametrize("name", CONTACT)
def test_live_tracks_are_bounded_with_a_warning(name):
    """Two scans of dense clutter would open a track per pair in the window; max_tracks bounds them."""
    rng = np.random.default_rng(0)
    tracker = make_tracker(name, Sensor(), {"lifecycle": {"max_tracks": 50}})
    polar = lambda n: np.column_stack([rng.uniform(5_000, 8_000, n), rng.uniform(0, 0.3, n)])  # noqa: E731
    tracker.step(Scan(1, 2.0, polar(2_000)))
    with pytest.warns(BoundWarning, match=r"new track\(s\) refused, 0 live already and at most 50 allowed"):
        out = tracker.step(Scan(2, 4.0, polar(2_000)))
    assert len(out) == 50 and tracker.initiation.n_refused > 0
    refused = tracker.initiation.n_refused
    with warnings.catch_warnings(record=True) as later:
        warnings.simplefilter("always")
        for k in range(3, 6):
            assert len(tracker.step(Scan(k, 2.0 * k, polar(2_000)))) <= 50 + 50
    assert not [w for w in later if "refused" in str(w.message)]  # the first refusal of a run warns, later count
    assert tracker.initiation.n_refused > refused
    tracker.reset()
    assert tracker.initiation.n_refused == 0


@pytest.mark.parametrize("name, params, counter", [
    ("gnn", {"max_exact_pairs": 0}, "n_greedy"),
    ("jpda", {"max_joint_events": 1}, "n_approximated"),
    ("mht", {"max_hypotheses": 5}, None),
])
def test_work_bounds_warn_once_when_they_bite(name, params, counter):
    ds = generate(PRESETS["S2"], seed=1)
    tracker = make_tracker(name, ds.scenario.sensor, params)
    with pytest.warns(BoundWarning) as caught:
        for scan in ds.scans():
            tracker.step(scan)
    messages = [str(w.message) for w in caught if issubclass(w.category, BoundWarning)]
    for key in params:  # once per bound and run
        assert sum(f"(config field {key})" in m for m in messages) == 1, messages
    assert counter is None or getattr(tracker, counter) > 1


def test_joined_tracks_are_the_batch_concatenation():
    tracker = make_tracker("gnn", PRESETS["S1"].sensor)
    scans = list(generate(PRESETS["S1"], seed=0).scans())
    tracker.step(scans[0])
    tracker.step(scans[1])
    a = tracker.tracks
    tracker.step(scans[2])
    b = tracker.tracks
    joined, concat = a.joined(b), type(a).concat([a, b])
    assert len(joined) == len(a) + len(b) > 2
    for mine, theirs in zip(joined._arrays(), concat._arrays()):
        assert mine.dtype == theirs.dtype
        np.testing.assert_array_equal(mine, theirs)


def test_branched_tracks_are_the_rows_taken_with_the_new_filter_states_after_the_scan():
    """`tracks.branched_moved`, which MHT's and the labelled trackers' children take their records from: the rows
    ``parent`` taken and moved on by `Tracks.after_scan`."""
    tracker = make_tracker("gnn", PRESETS["S1"].sensor)
    scans = list(generate(PRESETS["S1"], seed=0).scans())
    for scan in scans[:3]:
        tracker.step(scan)
    tracks, after = tracker.tracks, tracker._checked(scans[3])
    parent = np.array([2, 0, 0, len(tracks) - 1])
    other = tracks.take(parent[::-1]).filt  # any filter states of the children's number
    contact = np.array([NO_CONTACT, 0, 1, NO_CONTACT])
    life = tracker.config.lifecycle
    status, counts, scores, history, *_ = branched_moved(
        parent, contact, np.ones(parent.size, np.bool_), tracks.status, tracks.counts, tracks.scores, tracks.history,
        *branching_args(life), after.xy, np.ascontiguousarray(after.z[:, 1]), after.time)
    branched = Tracks(tracks.track_id[parent], status, other, history, counts, scores)
    taken = tracks.take(parent).replaced(filt=other).after_scan(contact, other, after.z, after.xy, after.time, life)
    for mine, theirs in zip(branched._arrays(), taken._arrays()):
        assert mine.dtype == theirs.dtype
        np.testing.assert_array_equal(mine, theirs)


def test_gnn_stages_take_the_confirmed_tracks_pairs_then_the_free_contacts_of_the_rest():
    """`gnn._stage_pairs`: the confirmed (or the other) tracks' gated pairs whose contact no track holds yet, with
    their costs d^2 + log|S|, as the masks of the numpy formulation select them."""
    rng = np.random.default_rng(0)
    K, N = 12, 30
    rows = np.sort(rng.integers(0, K, 80))
    cols, d2, log_det = rng.integers(0, N, 80), rng.uniform(0, 9, 80), rng.normal(size=K)
    status = rng.choice(np.array([TrackStatus.PRELIMINARY, TrackStatus.CONFIRMED], np.int8), K)
    contact = np.where(rng.random(K) < 0.3, rng.integers(0, N, K), NO_CONTACT)
    taken = np.zeros(N, bool)
    taken[contact[contact != NO_CONTACT]] = True
    for confirmed in (True, False):
        sel = ((status[rows] == TrackStatus.CONFIRMED) == confirmed) & ~taken[cols]
        r, c, cost = _stage_pairs(confirmed, status, rows, cols, d2, log_det, contact, N)
        assert 0 < r.size < rows.size
        np.testing.assert_array_equal(r, rows[sel])
        np.testing.assert_array_equal(c, cols[sel])
        np.testing.assert_array_equal(cost, d2[sel] + log_det[rows[sel]])


def test_the_packed_track_fields_read_and_rescore_by_name():
    """`Tracks` packs its fields by kind: the named views read the right columns (a new track's history is
    its two contacts' times and positions), and `Tracks.rescored` changes the score alone (its maximum too
    with ``restart``), copying."""
    tracker = make_tracker("gnn", PRESETS["S1"].sensor, {"lifecycle": {"confirmation": "score"}})
    scans = list(generate(PRESETS["S1"], seed=0).scans())
    tracker.step(scans[0])
    tracker.step(scans[1])
    born = tracker.tracks
    assert len(born) > 2 and born.history.shape == (len(born), 8) and born.counts.shape == (len(born), 3)
    np.testing.assert_array_equal(born.t1, np.full(len(born), scans[0].time))
    np.testing.assert_array_equal(born.t0, born.t1)
    np.testing.assert_array_equal(born.t2, np.full(len(born), scans[1].time))
    np.testing.assert_array_equal(born.p2, born.filt.x[:, 0, [0, 2]])  # a two-point start sits on its fix
    assert born.p1.shape == born.p2.shape == (len(born), 2) and (born.hits == 0).all()
    assert np.isfinite(born.confirm_at).all() and (born.max_score == born.score).all()
    before = born.scores.copy()
    again = born.rescored(born.score + 1.0)
    np.testing.assert_array_equal(again.score, before[:, 0] + 1.0)
    np.testing.assert_array_equal(again.max_score, before[:, 1])
    np.testing.assert_array_equal(born.scores, before)  # the original is untouched
    restarted = born.rescored(np.zeros(len(born)), restart=True)
    assert (restarted.max_score == 0).all() and (restarted.confirm_at == born.confirm_at).all()
