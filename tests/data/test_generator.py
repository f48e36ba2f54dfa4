"""Statistics, gap tables, coverage and determinism of the scenario generator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from nnda.data.generator import generate, generate_runs
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.sensor import cart_to_polar, wrap_angle
from nnda.errors import ConfigError


def _band(sample_std: float, sigma: float, n: int, level: float = 0.99) -> bool:
    """Is a sample std inside the two-sided chi-square confidence band of sigma?"""
    lo, hi = stats.chi2.ppf([(1 - level) / 2, (1 + level) / 2], n - 1)
    s2 = sample_std**2 * (n - 1)
    return lo * sigma**2 <= s2 <= hi * sigma**2


def _noise_only(n_targets: int = 40, duration: float = 200.0) -> Scenario:
    """Targets circling the radar clockwise at 15 km (a right turn of a_n = V^2 / R): always in coverage."""
    v, radius = 120.0, 15_000.0
    bearings = np.linspace(0.0, 360.0, n_targets, endpoint=False)
    targets = [Target(name=f"t{i}", x_m=radius * np.sin(np.radians(b)), y_m=radius * np.cos(np.radians(b)),
                      heading_deg=b + 90.0, speed_m_s=v,
                      segments=[Segment(duration_s=duration, normal_accel=v**2 / radius)])
               for i, b in enumerate(bearings)]
    return Scenario(name="noise", duration_s=duration, targets=targets, clutter=Clutter(law="none"),
                    process_noise=ProcessNoise(model="none"))


def test_measurement_residuals_have_spec_sigmas():
    ds = generate(_noise_only(), seed=11)
    det, truth = ds.detections, ds.truth
    assert np.all(truth.detected)
    key = det.scan.astype(np.int64) * 1000 + det.target_id
    order = np.argsort(key)
    truth_key = truth.scan.astype(np.int64) * 1000 + truth.target_id
    rows = np.searchsorted(truth_key, key[order])  # truth is ordered by scan then target
    r_true, az_true = cart_to_polar(truth.x[rows], truth.y[rows])
    dr = det.range[order] - r_true
    daz = wrap_angle(det.azimuth[order] - az_true)
    n = dr.size
    assert n == 4000
    assert abs(dr.mean()) < 3 * 30.0 / np.sqrt(n) and abs(daz.mean()) < 3 * 3e-3 / np.sqrt(n)
    assert _band(dr.std(ddof=1), 30.0, n)
    assert _band(daz.std(ddof=1), 3e-3, n)
    assert abs(np.corrcoef(dr, daz)[0, 1]) < 3 / np.sqrt(n)


def test_band_helper_rejects_wrong_sigma():
    assert not _band(33.0, 30.0, 4000) and not _band(27.0, 30.0, 4000) and _band(30.0, 30.0, 4000)


def test_process_noise_is_position_jitter_of_4_m():
    sc = _noise_only(n_targets=20).model_copy(update={"process_noise": ProcessNoise()})
    clean = generate(sc.model_copy(update={"process_noise": ProcessNoise(model="none")}), seed=2).truth
    noisy = generate(sc, seed=2).truth
    jitter = np.concatenate([noisy.x - clean.x, noisy.y - clean.y])
    assert _band(jitter.std(ddof=1), 0.5 * 2.0**2 * 2.0, jitter.size)
    np.testing.assert_array_equal(noisy.vx, clean.vx)  # not accumulated into velocity (A2)


def test_fixed_clutter_count_per_scan_and_coverage():
    ds = generate(PRESETS["S1"], seed=4)
    det = ds.detections
    counts = np.bincount(det.scan[det.is_clutter], minlength=ds.n_scans + 1)[1:]
    assert np.all(counts == 100)
    assert det.range.min() >= 5_000 and det.range.max() <= 30_000


def test_poisson_clutter_count():
    sc = _noise_only(n_targets=1, duration=2000.0).model_copy(
        update={"clutter": Clutter(law="annulus", count=100, count_law="poisson")})
    ds = generate(sc, seed=5)
    counts = np.bincount(ds.detections.scan[ds.detections.is_clutter], minlength=ds.n_scans + 1)[1:]
    assert counts.size == 1000
    assert abs(counts.mean() - 100) < 4 * 10 / np.sqrt(1000)
    # Poisson dispersion index: var/mean ~ 1 (chi-square test)
    d = counts.var(ddof=1) * (counts.size - 1) / counts.mean()
    assert stats.chi2.ppf(0.005, counts.size - 1) < d < stats.chi2.ppf(0.995, counts.size - 1)


def test_annulus_clutter_is_uniform_over_coverage():
    sc = _noise_only(n_targets=1, duration=100.0).model_copy(update={"clutter": Clutter(law="annulus")})
    det = generate(sc, seed=6).detections
    r, az = det.range[det.is_clutter], det.azimuth[det.is_clutter]
    # uniform in area: r^2 uniform on [5 km^2, 30 km^2]; azimuth uniform on [0, 2 pi)
    assert stats.kstest(r**2, stats.uniform(5e3**2, 30e3**2 - 5e3**2).cdf).pvalue > 0.01
    assert stats.kstest(az, stats.uniform(0, 2 * np.pi).cdf).pvalue > 0.01


def test_square_clutter_is_uniform_inside_square():
    sq = Clutter(law="square", side_m=10_000.0, centre_m=(0.0, 15_000.0))
    sc = _noise_only(n_targets=1, duration=100.0).model_copy(update={"clutter": sq})
    det = generate(sc, seed=8).detections
    x, y = det.x[det.is_clutter], det.y[det.is_clutter]
    assert x.min() >= -5_000 and x.max() <= 5_000 and y.min() >= 10_000 and y.max() <= 20_000
    observed, _, _ = np.histogram2d(x, y, bins=10, range=[[-5e3, 5e3], [10e3, 20e3]])
    assert stats.chisquare(observed.ravel()).pvalue > 0.01


def test_square_clutter_partly_outside_coverage_is_redrawn_inside():
    sq = Clutter(law="square", side_m=16_600.0, centre_m=(0.0, 0.0))  # covers the radar's blind disc
    sc = _noise_only(n_targets=1, duration=20.0).model_copy(update={"clutter": sq})
    det = generate(sc, seed=9).detections
    r = det.range[det.is_clutter]
    assert r.size == 1000 and r.min() >= 5_000


def test_clutter_region_outside_coverage_is_an_error():
    sq = Clutter(law="square", side_m=1_000.0, centre_m=(0.0, 0.0))
    sc = _noise_only(n_targets=1, duration=20.0).model_copy(update={"clutter": sq})
    with pytest.raises(ConfigError, match=r"clutter of sensor 'radar': the square region .* has 0.00% of its "
                                          r"points inside the coverage"):
        generate(sc, seed=1)


@pytest.mark.parametrize("name", ["train02", "train14", "S3", "S5"])
def test_no_target_detection_in_exactly_the_scripted_scans(name):
    sc = PRESETS[name]
    ds = generate(sc, seed=12)
    for tid, target in enumerate(sc.targets):
        rows = ds.truth.target_id == tid
        missed = set(ds.truth.scan[rows][~ds.truth.detected[rows]].tolist())
        assert missed == set(target.missed_scans)
        detected_scans = ds.detections.scan[ds.detections.target_id == tid]
        assert set(detected_scans.tolist()) == set(ds.truth.scan[rows].tolist()) - set(target.missed_scans)


def test_detection_probability():
    sc = _noise_only(n_targets=10, duration=400.0).model_copy(update={"sensor": Sensor(pd=0.8)})
    truth = generate(sc, seed=13).truth
    n = truth.detected.size
    assert abs(truth.detected.mean() - 0.8) < 4 * np.sqrt(0.16 / n)


def test_targets_outside_coverage_are_not_detected():
    inbound = Target(name="in", x_m=0.0, y_m=7_000.0, heading_deg=180.0, speed_m_s=100.0,
                     segments=[Segment(duration_s=60.0)])
    sc = Scenario(name="blind", duration_s=60.0, targets=[inbound], clutter=Clutter(law="none"))
    ds = generate(sc, seed=1)
    r = np.hypot(ds.truth.x, ds.truth.y)
    assert not ds.truth.detected[r < 4_800].any()
    assert ds.truth.detected[r > 5_200].all()


def test_target_exists_only_during_its_trajectory():
    late = Target(name="late", x_m=0.0, y_m=12_000.0, heading_deg=90.0, speed_m_s=100.0,
                  start_time_s=10.0, segments=[Segment(duration_s=20.0)])
    sc = Scenario(name="life", duration_s=60.0, targets=[late], clutter=Clutter(law="none"))
    truth = generate(sc, seed=1).truth
    assert truth.scan.tolist() == list(range(5, 16))  # t = 10 .. 30 s


def test_same_seed_same_data_and_runs_are_independent_of_the_batch():
    sc = PRESETS["S2"]
    a = generate(sc, seed=21, run=3)
    b = list(generate_runs(sc, range(5), seed=21))[3]
    for field in ("range", "azimuth", "scan", "target_id"):
        np.testing.assert_array_equal(getattr(a.detections, field), getattr(b.detections, field))
    c = generate(sc, seed=22, run=3)
    assert not np.array_equal(a.detections.range[:50], c.detections.range[:50])
    d = generate(sc, seed=21, run=4)
    assert not np.array_equal(a.detections.range[:50], d.detections.range[:50])


def test_clutter_law_change_keeps_target_noise():
    sc = PRESETS["train05"]
    a = generate(sc, seed=1)
    b = generate(sc.model_copy(update={"clutter": Clutter(law="annulus")}), seed=1)
    ta, tb = a.detections.target_id >= 0, b.detections.target_id >= 0
    np.testing.assert_array_equal(a.detections.range[ta], b.detections.range[tb])


def test_detections_are_ordered_by_scan_then_azimuth():
    det = generate(PRESETS["S6"], seed=1).detections
    key = det.scan * 10.0 + det.azimuth  # azimuth < 2 pi < 10
    assert np.all(np.diff(key) >= 0)
