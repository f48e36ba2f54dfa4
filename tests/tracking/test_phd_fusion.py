"""Fusion of local GM-PHD filters (the harbour of Lima 2022): the fusion rules on hand-made intensities, the
centralised update against single-sensor updates in turn, and every method on the harbour without occlusion."""

from __future__ import annotations

import numpy as np
import pytest
from test_phd_trackers import confirmed_after

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter
from nnda.data.sensor import in_coverage
from nnda.errors import ConfigError
from nnda.filters.mixture import Mixture
from nnda.study.metrics import run_metrics
from nnda.tracking.phd import config as phd_config
from nnda.tracking.phd.fusion import CentralPHDTracker, coverage_shares, fuse
from nnda.tracking.registry import make_tracker
from tolerances import RTOL

HARBOUR = PRESETS["harbour"]


def assert_close(actual, desired):
    np.testing.assert_allclose(actual, desired, rtol=RTOL, atol=1e-9)


def _ship(x: float, y: float, w: float = 1.0, label: int = 0) -> Mixture:
    P = np.diag([400.0, 4.0, 400.0, 4.0, 1e-4])
    return Mixture.make([w], [[x, 3.0, y, -1.0, 0.01]], [P], [label])


def test_two_radars_seeing_one_ship_fuse_to_one_component_of_both_weights():
    """The union holds two components, the fusion one: union and merge counts the ship twice, AA once."""
    a, b = _ship(1_000.0, 5_000.0, 0.95, 3), _ship(1_020.0, 4_990.0, 0.9, 7)
    union = Mixture.concat([a, b])
    fused, groups = fuse(union, 25.0)
    assert len(union) == 2 and len(fused) == 1 and groups.tolist() == [0, 0]
    assert fused.weights[0] == pytest.approx(1.85) and fused.labels[0] == 3  # the heavier's label
    shares = coverage_shares(HARBOUR.sensors, np.array([0, 1]), union.means)
    assert shares.tolist() == [0.5, 0.5]
    aa, _ = fuse(Mixture(union.weights * shares, union.means, union.covariances, union.labels), 25.0)
    assert aa.weights[0] == pytest.approx(0.925)
    assert_close(aa.means[0], (0.95 * a.means[0] + 0.9 * b.means[0]) / 1.85)


def test_aa_fusion_of_two_identical_intensities_is_that_intensity():
    one = Mixture.concat([_ship(1_000.0, 5_000.0, 0.97, 0), _ship(-2_000.0, 4_000.0, 0.6, 1)])
    union = Mixture.concat([one, one])
    shares = coverage_shares(HARBOUR.sensors, np.array([0, 0, 1, 1]), union.means)
    fused, _ = fuse(Mixture(union.weights * shares, union.means, union.covariances, union.labels), 25.0)
    order = np.argsort(fused.labels)
    assert_close(fused.weights[order], one.weights)
    assert_close(fused.means[order], one.means)
    assert_close(fused.covariances[order], one.covariances)


def test_a_ship_only_one_radar_covers_keeps_its_whole_weight():
    far = _ship(-4_000.0 + 11_500.0, 9_000.0 - 1_000.0)  # inside radar 2's sector, beyond radar 1's 12 km
    seen = [bool(s) for s in coverage_shares(HARBOUR.sensors, np.array([0, 1]), np.repeat(far.means, 2, axis=0))]
    assert seen == [False, True]
    nowhere = _ship(30_000.0, 30_000.0)
    assert coverage_shares(HARBOUR.sensors, np.array([0]), nowhere.means).tolist() == [0.5]


def test_gci_counts_a_ship_both_radars_hold_once_and_one_radar_alone_holds_by_its_coverage_rule():
    """The geometric mean of two identical Gaussians of weights 0.95 and 0.9 is that Gaussian at weight
    sqrt(0.95 x 0.9), keyed by the first radar's component; a ship radar 2's intensity lacks is lost ("drop"),
    or passes unchanged when it lies outside radar 2's coverage ("keep")."""
    near = (6_000.0, 500.0)  # a mile from radar 1, beyond radar 2's 12 km
    assert [bool(in_coverage(s, np.array([near[0]]), np.array([near[1]]))[0]) for s in HARBOUR.sensors] == [True,
                                                                                                          False]
    seen_by_both = (1_000.0, 5_000.0)
    a = Mixture.concat([_ship(*seen_by_both, 0.95, 3), _ship(*near, 0.7, 4)])
    b = _ship(*seen_by_both, 0.9, 7)
    plain = make_tracker("fusion-gci", HARBOUR.sensors)
    assert plain.config.omega == 0.5 and plain.config.fused_extraction_threshold == 0.1
    fused = plain._combined([a, b])
    assert len(fused) == 1 and fused.labels.tolist() == [3 * 2 + 0]
    assert fused.weights[0] == pytest.approx(np.sqrt(0.95 * 0.9), rel=1e-12)
    assert_close(fused.means[0], a.means[0])
    keep = make_tracker("fusion-gci", HARBOUR.sensors, {"outside_coverage": "keep"})._combined([a, b])
    order = np.argsort(keep.labels)
    assert keep.labels[order].tolist() == [3 * 2, 4 * 2] and keep.weights[order][1] == 0.7
    skewed = make_tracker("fusion-gci", HARBOUR.sensors, {"omega": 0.25})._combined([a, b])
    assert skewed.weights[0] == pytest.approx(0.95 ** 0.25 * 0.9 ** 0.75, rel=1e-12)


def test_gci_fusion_tracks_the_harbour_without_occlusion_or_clutter():
    """40 s (every ship inside both radars' coverage): after 10 s most of the five ships reported at a sweep
    (the fused weight, below either radar's, falls under 0.1 at some of their misses), none false."""
    ships = [t.model_copy(update={"length_m": None}) for t in HARBOUR.targets]
    radars = tuple(s.model_copy(update={"clutter": Clutter(law="none")}) for s in HARBOUR.sensors)
    ds = generate(HARBOUR.model_copy(update={"targets": ships, "sensors": radars, "duration_s": 40.0}), seed=2)
    tracker = make_tracker("fusion-gci", ds.scenario.sensors)
    outs = [tracker.step(scan) for scan in ds.scans()]
    m = run_metrics(ds, outs, ownership="position")
    counts = np.array([len(o) for o in outs])[20:]
    assert 4.3 < counts.mean() <= 5.0 and counts.max() == 5 and m.false_tracks == 0


def test_the_central_update_is_the_single_sensor_updates_in_turn():
    """One GM-PHD on both radars equals a one-radar GM-PHD per radar handing its state to the other (each
    coasting a reported label through one miss, the two-sensor default, given to the one-radar filters too)."""
    # both radars cover every component (one coverage): where one sensor cannot see, the central update
    # gives p_D 0 and a single-sensor one p_D everywhere
    radars = tuple(s.model_copy(update={"fov_deg": 360.0, "max_range_m": 40_000.0}) for s in HARBOUR.sensors)
    sc = HARBOUR.model_copy(update={"sensors": radars, "duration_s": 40.0})
    ds = generate(sc, seed=1)
    central = CentralPHDTracker(radars)
    alone = [CentralPHDTracker(r, phd_config.CentralPHDConfig(coast_misses=1)) for r in radars]
    last = None
    for scan in ds.scans():
        out = central.step(scan)
        f = alone[scan.sensor]
        if last is not None:
            f.mixture, f.newborn, f.next_label, f.last_time, f.confirmed_labels = (
                last.mixture, last.newborn, last.next_label, last.last_time, last.confirmed_labels)
        ref = f.step(Scan(scan.index, scan.time, scan.measurements, 0))
        last = f
        assert np.array_equal(out.track_id, ref.track_id)
        assert_close(out.state, ref.state)
    assert len(central.mixture) > 5


@pytest.mark.parametrize("name", ["fusion-merge", "fusion-aa", "fusion-central", "mht", "gnn"])
def test_without_occlusion_or_clutter_every_method_counts_five_ships(name):
    ships = [t.model_copy(update={"length_m": None}) for t in HARBOUR.targets]
    radars = tuple(s.model_copy(update={"clutter": Clutter(law="none")}) for s in HARBOUR.sensors)
    ds = generate(HARBOUR.model_copy(update={"targets": ships, "sensors": radars}), seed=2)
    tracker = make_tracker(name, ds.scenario.sensors)
    outs = [tracker.step(scan) for scan in ds.scans()]
    m = run_metrics(ds, outs, ownership="position")
    after = slice(40, None)  # 20 s
    counts = np.array([len(o) for o in outs])[after]
    assert m.false_tracks <= (0 if name in ("mht", "gnn", "fusion-central") else 1)  # a brief split, once
    if name == "fusion-central":  # a lone PHD drops a ship's weight to 1 - p_D at every miss (and its label
        assert abs(tracker.cardinality.mean - 5.0) < 0.6 and counts.mean() > 4.2 and m.track_breaks <= 2  # may go)
    else:
        assert abs(counts.mean() - 5.0) < (0.05 if name in ("mht", "gnn") else 0.15) and m.track_breaks == 0


def test_fusion_configs_are_checked():
    with pytest.raises(ConfigError, match="sensor_pd gives 3 detection probabilities for 2 sensor"):
        make_tracker("fusion-aa", HARBOUR.sensors, {"sensor_pd": [0.9, 0.9, 0.9]})
    with pytest.raises(ConfigError, match="fused_extraction_threshold"):
        make_tracker("fusion-merge", HARBOUR.sensors, {"fused_extraction_threshold": 0.0})
    with pytest.raises(ConfigError, match="omega"):
        make_tracker("fusion-gci", HARBOUR.sensors, {"omega": 1.0})
    with pytest.raises(ConfigError, match="outside_coverage"):
        make_tracker("fusion-gci", HARBOUR.sensors, {"outside_coverage": "ignore"})


@pytest.mark.parametrize("name", ["fusion-central", "cphd"])
def test_a_filter_on_one_radar_of_two_is_the_filter_on_that_radar_alone(name):
    """``use_sensors``: the other radar's scans only predict; at the used radar's scans the output is that of
    the same filter on a scene of that radar alone (which draws the same contacts for it)."""
    ds = generate(HARBOUR.model_copy(update={"duration_s": 30.0}), seed=3)
    alone = generate(HARBOUR.model_copy(update={"duration_s": 30.0, "sensors": HARBOUR.sensors[:1]}), seed=3)
    both = make_tracker(name, ds.scenario.sensors, {"use_sensors": ["radar1"]})
    one = make_tracker(name, alone.scenario.sensors)
    mine = [both.step(scan) for scan in ds.scans()]
    ref = [one.step(scan) for scan in alone.scans()]
    used = [o for o, s in zip(mine, ds.scan_sensor) if s == 0]
    assert len(used) == len(ref) and len(mine) == 2 * len(ref)
    for a, b in zip(used, ref):
        assert np.array_equal(a.track_id, b.track_id)
        assert_close(a.state, b.state)
    with pytest.raises(ConfigError, match="use_sensors names 'radar9'"):
        make_tracker(name, HARBOUR.sensors, {"use_sensors": ["radar9"]})


def test_harbour_config_is_a_deprecated_alias_of_central_phd_config():
    with pytest.warns(FutureWarning, match="HarbourConfig.*CentralPHDConfig"):
        old = phd_config.HarbourConfig
    assert old is phd_config.CentralPHDConfig
    assert CentralPHDTracker.config_type is phd_config.CentralPHDConfig
    assert phd_config.CentralPHDConfig().preset == "harbour"


@pytest.mark.parametrize("name", ["ekphd", "cphd", "fusion-central", "fusion-merge", "fusion-aa"])
def test_extraction_over_sweeps_counts_each_radars_sweeps_apart(name):
    """With two radars in turn, the default (3 sweeps) reports at a sweep the ids a one-scan extraction
    reports there that it has reported after three sweeps in a row of one radar (each radar's counted apart,
    whatever the other's sweeps between them reported): the filter and its ids are those of
    extraction_scans 1 (neither coasting through a miss: that rule is tested apart)."""
    dense = HARBOUR.model_copy(update={"duration_s": 40.0, "sensors": PRESETS["harbour-dense"].sensors})
    ds = generate(dense, seed=4)
    every, default = make_tracker(name, ds.scenario.sensors, {"extraction_scans": 1, "coast_misses": 0}), make_tracker(
        name, ds.scenario.sensors, {"coast_misses": 0})
    assert default.config.extraction_scans == 3
    seen: dict[int, list[set]] = {0: [], 1: []}
    confirmed, confirmed_in_a_row = set(), set()
    in_a_row: list[set] = []  # every scan, both radars'
    fewer = differs = 0
    for scan in ds.scans():
        out, kept = every.step(scan), default.step(scan)
        seen[scan.sensor].append(set(out.track_id.tolist()))
        in_a_row.append(set(out.track_id.tolist()))
        expected = confirmed_after(3, seen[scan.sensor], confirmed)
        assert set(kept.track_id.tolist()) == expected
        fewer += len(out) - len(kept)
        differs += expected != confirmed_after(3, in_a_row, confirmed_in_a_row)  # a count over all scans
    assert fewer > 0 and differs > 0
