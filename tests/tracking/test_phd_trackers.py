"""The PHD trackers (`nnda.tracking.phd.tracker`): the Kalman oracle, configs and their errors, presets,
Cartesian fixes, births, spawning, CT motion and the cardinality records."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.data.sensor import polar_to_cart
from nnda.errors import ConfigError, TrackingError
from nnda.filters import kalman, unscented
from nnda.filters.measurement import PolarMeasurement, PositionMeasurement
from nnda.filters.motion import ConstantVelocity
from nnda.study.metrics import run_metrics
from nnda.tracking.output import CONFIRMED, NO_CONTACT
from nnda.tracking.phd.config import CONFIRMATION_PRESETS, REDUCTION_PRESETS, CommonConfig
from nnda.tracking.phd.extraction import persistent
from nnda.tracking.phd.tracker import CPHDTracker, GMPHDTracker
from nnda.tracking.registry import TRACKERS, make_tracker
from tolerances import assert_state

PHD = ["gmphd", "ekphd", "ukphd", "cphd"]


def lone_target() -> Scenario:
    """One manoeuvring target, no clutter, detected every scan (the sensor's PD is 1)."""
    t = Target(name="lone", x_m=-9_000.0, y_m=12_000.0, heading_deg=60.0, speed_m_s=150.0,
               segments=[Segment(duration_s=40.0), Segment(duration_s=40.0, turn_rate_deg_s=2.0)])
    return Scenario(name="lone", duration_s=80.0, targets=[t], clutter=Clutter(law="none"))


def oracle_config(m0, P0, **extra) -> dict:
    """p_D = p_S = 1, no clutter, one static birth of weight 1 at the first scan only (the oracle birth),
    every extracted component reported."""
    return {"pd": 1.0, "ps": 1.0, "clutter": 0.0, "extraction_scans": 1,  # reported from the first scan
            "birth": {"kind": "static", "every_scan": False,
                      "components": [{"weight": 1.0, "mean": list(m0), "covariance": P0.tolist()}]}, **extra}


def assert_close(a, b, P):
    """States within 1e-9 of their own size (or of their standard deviation)."""
    np.testing.assert_array_less(np.abs(a - b), 1e-9 * np.maximum(np.abs(b), np.sqrt(np.diag(P))) + 1e-300)


@pytest.mark.parametrize("name", ["gmphd", "gmphd-cartesian", "ekphd", "ukphd", "cphd"])
def test_one_target_without_clutter_is_a_kalman_filter(name):
    """One target, no clutter, p_D 1: the single component is the Kalman filter (EKF, UKF, converted or
    Cartesian-fix KF) step for step, to 1e-9."""
    ds = generate(lone_target(), seed=5)
    scans = list(ds.scans())
    sensor, radar = ds.scenario.sensor, PolarMeasurement.from_sensor(ds.scenario.sensor)
    xy0, _ = radar.position(scans[0].measurements)
    m0 = np.array([xy0[0, 0], -100.0, xy0[0, 1], 60.0])
    P0 = np.diag([200.0**2, 150.0**2, 200.0**2, 150.0**2])
    kind = name.split("-")[0]
    cartesian = name.endswith("cartesian")
    fixes = PositionMeasurement(((40.0**2, 0.0), (0.0, 40.0**2)))
    if cartesian:  # the contacts as Cartesian fixes
        scans = [Scan(s.index, s.time, np.column_stack(polar_to_cart(*s.measurements.T))) for s in scans]
    tracker = TRACKERS[kind](sensor, TRACKERS[kind].config_type.model_validate(
        oracle_config(m0, P0, **({"max_cardinality": 5} if kind == "cphd" else {}))),
        measurement=fixes if cartesian else None)
    cv = ConstantVelocity(10.0)
    x, P, t = m0[None], P0[None], scans[0].time
    for k, scan in enumerate(scans):
        if k:
            x, P = kalman.predict(x, P, cv, scan.time - t)
        z = scan.measurements
        if kind == "gmphd":
            model = fixes if cartesian else PositionMeasurement(tuple(map(tuple, radar.position(z)[1][0])))
            zz = z if cartesian else radar.position(z)[0]
            mp = kalman.predict_measurement(x, P, model)
        else:
            model, zz = radar, z
            mp = (unscented.predict_measurement(x, P, radar) if kind == "ukphd"
                  else kalman.predict_measurement(x, P, radar))
        x, P, _ = kalman.update(x, P, zz, mp, model)
        t = scan.time
        out = tracker.step(scan)
        assert len(out) == 1 and len(tracker.mixture) == 1
        assert tracker.mixture.weights[0] == pytest.approx(1.0, rel=1e-12)
        assert_close(out.state[0], x[0], P[0])
        np.testing.assert_array_less(np.abs(out.covariance[0] - P[0]),
                                     1e-9 * np.sqrt(np.outer(np.diag(P[0]), np.diag(P[0]))))
        assert out.contact[0] == NO_CONTACT and out.status[0] == CONFIRMED
        if kind == "cphd":
            assert tracker.cardinality.map == 1 and tracker.cardinality.distribution[1] == pytest.approx(1.0)


def test_cphd_cardinality_concentrates_on_the_true_count_without_clutter():
    """Away from the scans where targets end (with p_S 0.99 and p_D 0.9 the filter takes a few misses to
    believe a death), the MAP count is the true one and holds nearly all the probability."""
    sc = PRESETS["S6"].model_copy(update={"clutter": Clutter(law="none")})
    ds = generate(sc, seed=2)
    tracker = make_tracker("cphd", ds.scenario.sensor, {"clutter": "scan"})
    n_true = np.bincount(ds.truth.scan, minlength=ds.n_scans + 2)
    steady = [k for k in range(4, ds.n_scans + 1) if len(set(n_true[k - 3:k + 1])) == 1]
    right, mass = [], []
    for scan in ds.scans():
        tracker.step(scan)
        c = tracker.cardinality
        assert c.distribution.sum() == pytest.approx(1.0) and c.mean == pytest.approx(np.arange(101) @ c.distribution)
        if scan.index in steady:
            right.append(c.map == n_true[scan.index])
            mass.append(c.distribution[n_true[scan.index]])
    assert len(steady) > 80 and all(right) and min(mass) > 0.4 and np.median(mass) > 0.9


def test_gmphd_cardinality_record_is_the_weight_total():
    ds = generate(PRESETS["S4"], seed=1)
    tracker = make_tracker("ekphd", ds.scenario.sensor)
    for scan in list(ds.scans())[:20]:
        out = tracker.step(scan)
        c = tracker.cardinality
        assert c.map is None and c.distribution is None and c.extracted == len(out)
        assert (c.scan, c.time) == (scan.index, scan.time)
        # the record is the updated intensity's total before reduction: pruning and merging change it little
        assert c.mean == pytest.approx(tracker.mixture.weights.sum(), rel=0.1, abs=0.02)
    assert 3.0 < c.mean < 6.0


def test_presets_and_overrides():
    for name in PHD:
        for preset, values in REDUCTION_PRESETS.items():
            cfg = make_tracker(name, Sensor(), {"preset": preset}).config
            assert {k: getattr(cfg, k) for k in values} == values
            values = CONFIRMATION_PRESETS[preset]
            assert {k: getattr(cfg, k) for k in values} == values
    for name in PHD + ["fusion-merge", "fusion-aa", "fusion-central"]:  # the radar and harbour presets: on
        cfg = make_tracker(name, PRESETS["harbour"].sensors).config
        assert (cfg.components_per_contact, cfg.extraction_scans) == (1.0, 3)
    cfg = make_tracker("ekphd", Sensor(), {"preset": "pedestrian", "linearisation": "linear"}).config
    assert (cfg.components_per_contact, cfg.extraction_scans) == (None, 1)  # Frencl (2014)'s: off
    cfg = make_tracker("cphd", Sensor(), {"components_per_contact": 0, "extraction_scans": 1}).config
    assert (cfg.components_per_contact, cfg.extraction_scans) == (0, 1)  # explicit fields override the preset
    assert "extraction_scans" not in CommonConfig.model_fields  # the peer's config takes no such preset field
    assert CommonConfig(preset="radar").max_components == 100
    cfg = make_tracker("ekphd", Sensor(), {"preset": "harbour", "max_components": 200}).config
    assert (cfg.prune_threshold, cfg.merge_threshold, cfg.max_components, cfg.extraction_threshold) == (
        1e-6, 25.0, 200, 0.8)
    assert make_tracker("gmphd", Sensor()).config.linearisation == "linear"
    assert make_tracker("ukphd", Sensor()).config.linearisation == "ukf"
    assert make_tracker("cphd", Sensor()).config.linearisation == "ekf"
    again = type(cfg).model_validate(cfg.model_dump())  # a dumped config reads back the same
    assert again == cfg


@pytest.mark.parametrize(("field", "old", "new", "extra"), [
    ("preset", "seed-000", "pedestrian", {}),  # deprecated spelling
    ("preset", "seed-002", "harbour", {}),  # deprecated spelling
    ("motion", "cv-seed-000", "cv-diagonal", {}),  # deprecated spelling
    ("motion", "ncsht-seed-000", "ncsht", {"linearisation": "linear"}),  # deprecated spelling
])
def test_old_preset_and_motion_names_are_read_with_a_future_warning(field, old, new, extra):
    config_type = TRACKERS["ekphd"].config_type
    with pytest.warns(FutureWarning, match=f"{old}.*{new}") as caught:
        cfg = config_type(**{field: old, **extra})
    assert len([w for w in caught if issubclass(w.category, FutureWarning)]) == 1
    assert cfg == config_type(**{field: new, **extra})
    assert getattr(cfg, field) == new


@pytest.mark.parametrize("params, message", [
    ({"pd": 1.2}, "pd: Input should be less than or equal to 1"),
    ({"ps": -0.1}, "ps: Input should be greater than 0"),
    ({"pd": 0.0}, "pd: Input should be greater than 0"),
    ({"max_components": 0}, "max_components: Input should be greater than or equal to 1"),
    ({"preset": "walkers"}, "preset: Input should be"),
    ({"birth": {"kind": "static", "components": [
        {"weight": 1.0, "mean": [0, 0, 0], "covariance": np.eye(3).tolist()}]}},
     r"birth.components.0.mean: the cv state has 4 entries"),
    ({"motion": "ct", "birth": {"kind": "static", "components": [
        {"weight": 1.0, "mean": [0, 0, 1e4, 0], "covariance": np.eye(4).tolist()}]}}, "the ct state has 5 entries"),
    ({"birth": {"kind": "static", "components": [{"weight": 1.0, "mean": [0, 0, 1e4, 0],
                                                  "covariance": (-np.eye(4)).tolist()}]}}, "not positive definite"),
    ({"spawn": {"weight": 0.05, "covariance": np.eye(5).tolist()}}, "spawn.covariance: expected a 4 x 4 matrix"),
    ({"birth": {"rate": -1}}, "birth.measurement.rate"),
    ({"extraction_threshold": 0}, "extraction_threshold"),
    ({"linearisation": "ukf", "unscented": {"kappa": -4.0}}, "unscented.kappa: n \\+ kappa must be > 0"),
    ({"clutter": "everywhere"}, "clutter"),
    ({"gating": 9.0}, "gating: Extra inputs are not permitted"),
])
def test_bad_configs_are_refused_when_configured(params, message):
    with pytest.raises(ConfigError, match=message):
        make_tracker("ekphd", Sensor(), params)


def test_cphd_specific_settings():
    with pytest.raises(ConfigError, match="spawn: .*no spawning"):
        make_tracker("cphd", Sensor(), {"spawn": {"weight": 0.05, "covariance": np.eye(4).tolist()}})
    with pytest.raises(ConfigError, match="max_cardinality"):
        make_tracker("cphd", Sensor(), {"max_cardinality": 0})


@pytest.mark.parametrize("kind", ["ekphd", "ukphd"])
def test_on_cartesian_fixes_the_ek_and_uk_phd_differ_from_the_gmphd_only_in_the_prediction(kind):
    """On Cartesian fixes every linearisation's update is the linear one; with the (linear) CV motion the
    EKF's and the unscented prediction are exact too, so the EK-PHD and UK-PHD report what the GM-PHD does."""
    ds = generate(PRESETS["S1"], seed=3)
    fixes = PositionMeasurement(((60.0**2, 0.0), (0.0, 60.0**2)))
    a, b = GMPHDTracker(ds.scenario.sensor, measurement=fixes), TRACKERS[kind](ds.scenario.sensor, measurement=fixes)
    assert b.views[0].volume == a.views[0].volume and not b.views[0].polar
    for s in list(ds.scans())[:12]:
        scan = Scan(s.index, s.time, np.column_stack(polar_to_cart(*s.measurements.T)))
        oa, ob = a.step(scan), b.step(scan)
        np.testing.assert_array_equal(oa.track_id, ob.track_id)
        assert_state(ob.state, oa.state, oa.covariance)


def test_cartesian_fixes():
    """gmphd on Cartesian (x, y) fixes (a PositionMeasurement) follows S1's targets; bad fixes are refused."""
    ds = generate(PRESETS["S1"], seed=3)
    fixes = PositionMeasurement(((60.0**2, 0.0), (0.0, 60.0**2)))
    tracker = GMPHDTracker(ds.scenario.sensor, measurement=fixes)
    outs = [tracker.step(Scan(s.index, s.time, np.column_stack(polar_to_cart(*s.measurements.T))))
            for s in ds.scans()]
    m = run_metrics(ds, outs, ownership="position")
    assert m.mota >= 0.88 and m.position_rmse_m < 80.0 and m.track_breaks <= 2
    tracker.reset()
    tracker.step(Scan(1, 2.0, np.array([[-5_000.0, -3_000.0]])))  # negative coordinates are fine
    with pytest.raises(TrackingError, match="does not come after"):
        tracker.step(Scan(2, 2.0, np.array([[1.0, 2.0]])))
    with pytest.raises(TrackingError, match="contact 1 is invalid"):
        tracker.step(Scan(2, 4.0, np.array([[1.0, 2.0], [np.inf, 0.0]])))
    with pytest.raises(TrackingError, match=r"shape \(N, 2\) \[x m, y m\]"):
        tracker.step(Scan(2, 4.0, np.ones((2, 3))))


def test_static_birth_every_scan_spawning_and_ct():
    """Seed 000's options: a static birth over the scene every scan, spawning, and the CT model."""
    ds = generate(PRESETS["S2"], seed=3)
    births = [{"weight": 0.05, "mean": [x, 0.0, y, 0.0], "covariance": np.diag([4e6, 1e4, 4e6, 1e4]).tolist()}
              for x, y in [(-18_000.0, 6_000.0), (-12_000.0, -14_000.0), (2_000.0, -22_000.0), (-12_200.0, -13_800.0)]]
    static = make_tracker("ekphd", ds.scenario.sensor, {"birth": {"kind": "static", "components": births}})
    m = run_metrics(ds, [static.step(s) for s in ds.scans()], ownership="position")
    assert m.mota >= 0.88 and m.position_rmse_m < 80.0
    spawning = make_tracker("ekphd", ds.scenario.sensor,
                            {"spawn": {"weight": 0.01, "covariance": np.diag([1e4, 400.0, 1e4, 400.0]).tolist()}})
    m = run_metrics(ds, [spawning.step(s) for s in ds.scans()], ownership="position")
    assert m.mota >= 0.88 and m.position_rmse_m < 80.0
    ct = make_tracker("ekphd", ds.scenario.sensor, {"motion": "ct", "sigma_q": 5.0})
    outs = [ct.step(s) for s in ds.scans()]
    assert ct.mixture.dim == 5 and outs[-1].state.shape[1] == 4
    m = run_metrics(ds, outs, ownership="position")
    assert m.mota >= 0.88 and m.position_rmse_m < 80.0


def test_labels_are_unique_and_the_mixture_bounded():
    ds = generate(PRESETS["S6"], seed=4)
    tracker = make_tracker("ekphd", ds.scenario.sensor, {"max_components": 40, "components_per_contact": None})
    for scan in ds.scans():
        out = tracker.step(scan)
        assert np.unique(tracker.mixture.labels).size == len(tracker.mixture) <= 40
        assert np.unique(out.track_id).size == len(out)
        assert (np.diff(out.track_id) > 0).all()  # reported in label order


def test_map_extraction_reports_the_map_count():
    ds = generate(PRESETS["S1"], seed=3)
    tracker = make_tracker("cphd", ds.scenario.sensor, {"extraction": "map", "extraction_scans": 1})
    for scan in ds.scans():
        out = tracker.step(scan)
        assert len(out) == min(tracker.cardinality.map, len(tracker.mixture))


def test_the_cphd_is_its_own_class():
    assert issubclass(CPHDTracker, GMPHDTracker) and CPHDTracker.name == "cphd"


def test_persistence_counts_each_sensors_sweeps_apart():
    """Label 7 is extracted after every sweep of sensor 0 and none of sensor 1's (sweeps in turn): it is
    reported from sensor 0's third sweep on, though it was never extracted three scans in a row; label 9, at
    every sweep of both, from the third sweep of either; a confirmed label that leaves the mixture is forgotten."""
    records = [(np.empty(0, np.int64), np.empty(0, np.int64))] * 2
    confirmed = np.empty(0, np.int64)
    reported = []
    for scan in range(8):
        sensor = scan % 2
        labels = np.array([7, 9] if scan < 6 else [9])
        shown = np.array([0, 1]) if sensor == 0 and scan < 6 else np.flatnonzero(labels == 9)
        kept, records[sensor], confirmed = persistent(labels, shown, records[sensor], confirmed, 3)
        reported.append(labels[kept].tolist())
    assert reported == [[], [], [], [], [7, 9], [9], [9], [9]]
    assert confirmed.tolist() == [9]


def test_streaks_against_a_loop_over_scans():
    from nnda.tracking.phd.extraction import streaks
    rng = np.random.default_rng(5)
    history = [np.unique(rng.integers(0, 12, rng.integers(0, 8))) for _ in range(30)]
    last = (np.empty(0, np.int64), np.empty(0, np.int64))
    for t, labels in enumerate(history):
        got = streaks(labels, *last)
        for label, run in zip(labels, got, strict=True):  # the oracle: count back over the scans
            expected = next((t - s for s in range(t, -1, -1) if label not in history[s]), t + 1)
            assert run == expected
        last = (labels, got)


def confirmed_after(k: int, reported: list[set], confirmed: set) -> set:
    """The oracle of ``extraction_scans`` = k over one sensor's sweeps: ``confirmed`` (updated) with the labels
    reported with k = 1 after each of the last k sweeps; returns the labels to report now (those of the last
    sweep that are confirmed)."""
    if len(reported) >= k:
        confirmed |= set.intersection(*reported[-k:])
    return reported[-1] & confirmed


@pytest.mark.parametrize("name", ["ekphd", "cphd"])
def test_extraction_over_scans_reports_labels_once_extracted_k_scans_in_a_row(name):
    """extraction_scans = 3 leaves the filter as it is and reports, of the components a one-scan extraction
    reports, the labels it has reported in three scans in a row, then whenever it reports them."""
    ds = generate(PRESETS["S3"], seed=1)  # S3: targets missed for a few scans
    every, persistent = (make_tracker(name, ds.scenario.sensor, {"extraction_scans": k}) for k in (1, 3))
    assert make_tracker(name, ds.scenario.sensor).config.extraction_scans == 3  # the radar preset's
    reported, confirmed, fewer, back = [], set(), 0, 0
    for scan in ds.scans():
        out, kept = every.step(scan), persistent.step(scan)
        reported.append(set(out.track_id.tolist()))
        assert set(kept.track_id.tolist()) == confirmed_after(3, reported, confirmed)
        fewer += len(out) - len(kept)
        # a confirmed label back after a scan below the threshold: reported at once
        back += len(reported) >= 2 and bool((reported[-1] - reported[-2]) & set(kept.track_id.tolist()))
    assert fewer > 0 and back > 0


def test_the_component_cap_grows_with_the_contacts():
    sc = PRESETS["S1"]
    ds = generate(sc.model_copy(update={"clutter": sc.clutter.model_copy(update={"count": 400})}), 0)
    tracker = make_tracker("ekphd", ds.scenario.sensor, {"max_components": 50, "components_per_contact": 0.5})
    sizes = []
    for scan in ds.scans():
        tracker.step(scan)
        sizes.append(len(tracker.mixture))
        assert len(tracker.mixture) <= max(50, int(np.ceil(0.5 * len(scan.measurements))))
    assert max(sizes) > 50


def test_no_component_cap_per_contact_is_off():
    """components_per_contact 0 (what a TOML file can write) keeps J_max, as None does; the preset's 1 grows it."""
    sc = PRESETS["S1"]
    ds = generate(sc.model_copy(update={"clutter": sc.clutter.model_copy(update={"count": 400}),
                                        "duration_s": 20.0}), 0)
    sizes = {}
    for c in (0, None, 1.0):
        tracker = make_tracker("ekphd", ds.scenario.sensor, {"components_per_contact": c})
        sizes[c] = [(tracker.step(scan).track_id.tolist(), len(tracker.mixture)) for scan in ds.scans()]
    assert sizes[0] == sizes[None] and max(n for _, n in sizes[0]) == 100
    assert max(n for _, n in sizes[1.0]) > 300


@pytest.mark.parametrize("name", PHD)
def test_the_default_extraction_keeps_the_validation_clutter_out(name):
    """At the validation scenes' 100 clutter points a scan, the defaults (the radar preset: J_max grown with
    the contacts, a label reported after 3 sweeps in a row) confirm no false track where reporting every
    extracted component confirms several a run, and still follow every target."""
    new = old = 0
    for scene, seed in (("S1", 0), ("S3", 1)):
        ds = generate(PRESETS[scene].model_copy(update={"duration_s": 100.0}), seed)
        m, m_old = (run_metrics(ds, [t.step(scan) for scan in ds.scans()], ownership="position") for t in (
            make_tracker(name, ds.scenario.sensor),
            make_tracker(name, ds.scenario.sensor, {"components_per_contact": None, "extraction_scans": 1})))
        new, old = new + m.false_tracks, old + m_old.false_tracks
        assert m.lost_targets == 0 and m.mota > m_old.mota - 0.05
    assert new <= 1 and old >= 6, (new, old)


def test_coasting_adds_confirmed_labels_above_the_floor_in_label_order():
    from nnda.tracking.phd.extraction import coasting
    weights = np.array([0.9, 0.08, 0.3, 0.02, 0.06])
    labels = np.array([12, 4, 9, 7, 30])
    shown = np.array([0])  # label 12, extracted
    got = coasting(weights, labels, shown, np.array([4, 7, 12]), 0.05)
    assert labels[got].tolist() == [4, 12]  # 7 is below the floor; 9 and 30 were never confirmed
    assert coasting(weights, labels, np.empty(0, np.int64), np.empty(0, np.int64), 0.05).size == 0


@pytest.mark.parametrize("name", ["gmphd", "ekphd"])
def test_a_reported_target_is_shown_through_its_misses_with_coast_misses(name):
    """A lone target without clutter, its contacts taken out of sweeps 8 (one miss) and 12-13 (two in a row),
    and gone after sweep 16: with ``coast_misses`` = 1 its label is reported at the single miss and at the first
    of the two, then hidden, and shown one sweep after its last contact; with 0 (the filter's plain extraction)
    each miss hides it. The label is the same throughout, and the filter is the same (only the report differs)."""
    ds = generate(lone_target(), seed=5)
    scans = [Scan(s.index, s.time, s.measurements[:0] if s.index in (8, 12, 13) or s.index > 16 else s.measurements,
                  s.sensor) for s in list(ds.scans())[:19]]
    reported = {}
    for coast in (0, 1):
        tracker = make_tracker(name, ds.scenario.sensor, {"pd": 0.9, "clutter": 1.0, "coast_misses": coast})
        outs = [tracker.step(s) for s in scans]
        reported[coast] = [o.track_id.tolist() for o in outs]
        mixture = tracker.mixture
    shown = {coast: [k + 1 for k, ids in enumerate(r) if ids] for coast, r in reported.items()}
    first = shown[0][0]
    assert shown[0] == [k for k in range(first, 17) if k not in (8, 12, 13)]
    assert shown[1] == [k for k in range(first, 18) if k != 13]
    assert len({i for ids in reported[1] for i in ids}) == 1  # one label throughout
    assert len(mixture)  # (the filter itself still holds the component)


def test_coasting_defaults_to_the_sensor_count_and_refuses_map_extraction():
    """None: 1 for a filter several sensors' sweeps update (the two-radar scene, the fusion centres), 0 for one
    (a single radar, or one radar of two picked by ``use_sensors``); the MAP extraction never coasts, and an explicit
    coast with it is refused, naming the field."""
    one, two = PRESETS["S1"].sensors, PRESETS["two-radars"].sensors
    assert make_tracker("ekphd", one).coast_misses == 0
    assert make_tracker("ekphd", two).coast_misses == 1
    assert make_tracker("ekphd", two, {"use_sensors": [two[0].name]}).coast_misses == 0
    assert make_tracker("ekphd", two, {"coast_misses": 0}).coast_misses == 0
    assert make_tracker("fusion-aa", two).coast_misses == 1
    assert make_tracker("cphd", two, {"extraction": "map"}).coast_misses == 0
    with pytest.raises(ConfigError, match="coast_misses"):
        make_tracker("cphd", one, {"extraction": "map", "coast_misses": 1})


def test_first_sweep_births_weigh_each_contact_by_its_square():
    """Each contact's newborn weighs 1/n^2, n the contacts in the square of half-side r around it: clusters of 1,
    2, 3 and 5 contacts within 200 m, 20 km apart (so the count's square, its edges on a grid of r/4, holds its
    cluster whatever the grid); a lone contact's weighs 1."""
    from nnda.tracking.phd.birth import first_sweep_births
    rng = np.random.default_rng(3)
    sizes = [1, 2, 3, 5]
    xy = np.concatenate([[20_000.0 * k, -7_000.0 * k] + rng.uniform(-200.0, 200.0, (n, 2))
                         for k, n in enumerate(sizes)])
    cov = np.tile(np.diag([100.0**2, 100.0**2]), (len(xy), 1, 1))
    born = first_sweep_births(xy, cov, 3_000.0, 100.0, ConstantVelocity(), 7)
    n = np.repeat(sizes, sizes)
    np.testing.assert_allclose(born.weights, 1.0 / n**2, rtol=1e-9)
    assert born.weights[0] == 1.0 and born.labels.tolist() == list(range(7, 7 + len(xy)))


@pytest.mark.parametrize("name", ["ekphd", "cphd"])
def test_first_sweep_births_report_the_targets_present_from_the_start_sooner(name):
    """On S1 (its targets present from the first sweep) the first report comes sooner with the first sweep's
    births than without, and the report after it holds no fewer labels."""
    ds = generate(PRESETS["S1"], seed=0)
    first = {}
    for on in (True, False):
        tracker = make_tracker(name, ds.scenario.sensor, {"first_sweep_births": on})
        counts = [len(tracker.step(s)) for s in ds.scans()]
        first[on] = next(k for k, c in enumerate(counts) if c)
    assert first[True] < first[False]
