"""The track-before-detect study: its statistics against their definitions and the spec's worked numbers, the
divergence rule and RMSE against brute force, a tiny study end to end (files, seeds, bad config), and (slow)
the main comparison at the paper's setting."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import beta

from kind_study import run_kind
from nnda.app.study_commands import tbd
from nnda.errors import ConfigError, validated
from nnda.study.tbd import TBDStudyConfig, divergence, fisher, score, score_exit_reentry

TINY = {"runs": 3, "chunk_runs": 2, "scene": {"rows": 32, "cols": 32, "frames": 6},
        "filters": [{"name": "apf", "particles": 300}, {"name": "rs", "particles": 400}],
        "divergence_frames": 2, "steady_frames": 3, "acquisition": 2,
        "exit_reentry": {"runs": 2, "frames": 16, "exit_frames": 4, "reentry_frame": 10}}
TINY_TOML = """runs = 2
exit_reentry = {runs = 2, frames = 12, exit_frames = 3, reentry_frame = 8}
scene = {rows = 32, cols = 32, frames = 5}
filters = [{name = "apf", particles = 200}, {name = "rs", particles = 300}]
ptcr_db = [8.1]
divergence_frames = 2
steady_frames = 2
acquisition = 2
"""


def test_clopper_pearson_and_fisher_match_the_spec_and_the_beta_quantiles():
    """Spec A.4: 2/100 [0.24%, 7.0%], 3/100 [0.62%, 8.5%], 5/100 [1.6%, 11.3%]; Fisher 3 vs 5 p = 0.72, 2 vs 3
    p = 1."""
    for k, (lo, hi) in {2: (0.0024, 0.070), 3: (0.0062, 0.085), 5: (0.016, 0.113)}.items():
        d = divergence(k, 100, 0.95)
        assert d["ci_low"] == pytest.approx(lo, abs=5e-4) and d["ci_high"] == pytest.approx(hi, abs=5e-4)
        assert d["ci_low"] == pytest.approx(beta.ppf(0.025, k, 101 - k), rel=1e-9)
        assert d["ci_high"] == pytest.approx(beta.ppf(0.975, k + 1, 100 - k), rel=1e-9)
    assert fisher(divergence(3, 100, 0.95), divergence(5, 100, 0.95)) == pytest.approx(0.72, abs=0.01)
    assert fisher(divergence(2, 100, 0.95), divergence(3, 100, 0.95)) == pytest.approx(1.0)


def test_divergence_rule_and_rmse_against_brute_force():
    rng = np.random.default_rng(0)
    R, K = 40, 8
    cfg = TBDStudyConfig(scene={"frames": K}, divergence_frames=3, steady_frames=4, acquisition=2)
    truth = np.zeros((R, K, 5))
    truth[..., 0], truth[..., 2] = rng.uniform(10, 100, (2, R, K))
    truth[..., 4] = np.where(rng.random((R, K)) < 0.9, 1, 0)
    position = truth[..., [0, 2]] + rng.normal(0, 4, (R, K, 2))
    present = rng.random((R, K)) < 0.8
    s = score(truth, position, present, cfg)
    diverged, lost = [], np.zeros((R, K), dtype=bool)
    for r in range(R):
        for k in range(K):
            err = np.hypot(*(position[r, k] - truth[r, k, [0, 2]]))
            lost[r, k] = (not present[r, k] or err > 5.0) if truth[r, k, 4] else present[r, k]
        if lost[r, -3:].all():
            diverged.append(r)
    assert s["diverged_runs"] == diverged and s["divergence"]["count"] == len(diverged) > 0
    for k in range(K):
        kept = [r for r in range(R) if truth[r, k, 4] and r not in diverged]
        every = [r for r in range(R) if truth[r, k, 4]]
        for key, runs in (("rmse", kept), ("rmse_all", every)):
            ex = [position[r, k, 0] - truth[r, k, 0] for r in runs]
            assert s[key]["x"][k] == pytest.approx(np.sqrt(np.mean(np.square(ex))), rel=1e-9)
    on = truth[..., 4] > 0
    assert s["declared_present"] == pytest.approx(present[:, 2:][on[:, 2:]].mean())
    assert s["false_present"] == pytest.approx(present[~on].mean())


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return run_kind(tmp_path_factory.mktemp("tbd") / "out", "tbd", TINY)


def test_tiny_study_structure_and_seeds(tiny, tmp_path):
    assert [s["ptcr_db"] for s in tiny["settings"]] == [6.5, 8.1]
    s = tiny["settings"][0]
    assert set(s["filters"]) == {"apf@300", "rs@400"} and len(s["pairs"]) == 1
    apf, rs = s["filters"]["apf@300"], s["filters"]["rs@400"]
    assert apf["evaluations_per_frame"] == 600 and rs["evaluations_per_frame"] == 800
    assert len(apf["rmse"]["x"]) == 6 and apf["divergence"]["runs"] == 3
    assert set(s["paper"]) == {"apf@300", "rs@400"} and s["paper"]["apf@300"]["divergence"]["count"] == 3
    assert len(tiny["across_ptcr"]) == 2
    det = s["detector"]
    assert det["pfa"] == 1e-4 and 0 <= det["p_detection"] <= 1 and det["false_per_frame"] >= 0
    er = tiny["exit_reentry"]["filters"]["rs@400"]
    assert len(er["present_by_frame"]) == 16 and er["absent_frames"] > 0 and er["reacquire"]["events"] == 2
    again = run_kind(tmp_path / "again", "tbd", TINY, workers=2)  # blocks on other processes, in another order
    strip = lambda d: {k: v for k, v in d.items() if k not in ("seconds", "ms_per_frame")}  # noqa: E731
    for a, b in zip(tiny["settings"], again["settings"]):
        assert {k: strip(v) for k, v in a["filters"].items()} == {k: strip(v) for k, v in b["filters"].items()}


@pytest.mark.parametrize("change, match", [
    ({"filters": [{"name": "kalman", "particles": 10}]}, "unknown filter 'kalman'"),
    ({"divergence_frames": 30}, "more than the scene's 20 frames"),
    ({"exit_reentry": {"frames": 20, "reentry_frame": 25}}, "after the last of 20 frames"),
    ({"scene": {"beta_h": 0.3, "beta_v": 0.3}}, "positive-definite region"),
    ({"filters": [{"name": "apf", "particles": 10}, {"name": "apf", "particles": 10}]}, "names a filter twice"),
])
def test_bad_study_config_is_a_config_error(change, match):
    with pytest.raises(ConfigError, match=match):
        validated(TBDStudyConfig, change, "test", "tbd study")


def test_cli_writes_results_and_report_and_refuses_to_overwrite(tmp_path):
    (tmp_path / "tiny.toml").write_text(TINY_TOML)
    run = [sys.executable, "-m", "nnda", "tbd", "--config", "tiny.toml", "--out", "t", "--seed", "3"]
    done = subprocess.run(run, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    results = json.loads((tmp_path / "t" / "summary.json").read_text())["tbd"]
    assert results["config"]["seed"] == 3 and set(results["settings"][0]["filters"]) == {"apf@200", "rs@300"}
    md = (tmp_path / "t" / "report.md").read_text()
    assert "PTCR 8.1 dB: divergence, detection and cost" in md and "(paper: 2/100 vs 3/100)" in md
    assert "Exit and re-entry: 2 runs of 12 frames" in md and "per-frame detector (matched filter" in md
    assert "](figures/tbd-frames.png)" in md
    assert (tmp_path / "t" / "figures" / "tbd-frames.png").read_bytes()[:4] == b"\x89PNG"
    assert "<table" in (tmp_path / "t" / "report.html").read_text()
    with pytest.raises(FileExistsError, match="already exists"):
        tbd(out=tmp_path / "t", config=tmp_path / "tiny.toml")


@pytest.mark.slow
def test_paper_setting_main_comparison(tmp_path):
    """At the paper's setting (100 runs x 20 frames, APF 5,000, RS 8,000, the filters' own q): the APF within ~9%
    and RS within ~11% at 6.5 dB, the APF within ~9% at 8.1 dB (the upper 95% bounds of the paper's counts), no
    significant APF/RS difference at 6.5 dB, and no filter significantly worse at 8.1 dB than at 6.5 dB. (With
    the frames' q = 6 in the filters the APF diverged in 14/100 at 6.5 dB: the nearly frozen velocity.)"""
    table = {"filters": [{"name": "apf", "particles": 5000}, {"name": "rs", "particles": 8000}], "exit_reentry": None}
    r = run_kind(tmp_path / "out", "tbd", table, workers=2)
    low, high = r["settings"]
    assert low["filters"]["apf@5000"]["divergence"]["rate"] <= 0.09
    assert low["filters"]["rs@8000"]["divergence"]["rate"] <= 0.11
    assert high["filters"]["apf@5000"]["divergence"]["rate"] <= 0.09
    assert low["pairs"][0]["fisher_p"] > 0.05
    for a in r["across_ptcr"]:
        assert a["fisher_p"] > 0.05 or high["filters"][a["filter"]]["divergence"]["count"] <= \
            low["filters"][a["filter"]]["divergence"]["count"]


def test_exit_reentry_measures_on_a_crafted_run():
    """One run of 10 frames: present 1-3, absent 4-6, present 7-10; the filter acquires at frame 2, declares
    the exit at frame 5 and reacquires at frame 9."""
    cfg = TBDStudyConfig(scene={"frames": 10}, divergence_frames=2, steady_frames=2, acquisition=1)
    truth = np.zeros((1, 10, 5))
    truth[0, :, 0] = truth[0, :, 2] = 20.0
    truth[0, [0, 1, 2, 6, 7, 8, 9], 4] = 1
    position = truth[..., [0, 2]].copy()
    position[0, 6:8] += 9.0  # present but far: not acquired
    present = np.array([[False, True, True, True, False, True, True, True, True, True]])
    s = score_exit_reentry(truth, position, present, cfg)
    assert s["first_acquire"]["mean"] == 2 and s["reacquire"]["mean"] == 3 and s["exit_declared"]["mean"] == 2
    assert s["detection_rate"] == pytest.approx(6 / 7) and s["false_detection_rate"] == pytest.approx(2 / 3)
    assert s["present_by_frame"] == present[0].astype(float).tolist()


def test_exit_reentry_scenario_leaves_and_reenters():
    from nnda.data.frames import FramesConfig, simulate_truth

    cfg = FramesConfig(frames=50, scenario="exit-reentry", reentry_frame=30)
    for seed in range(5):
        z = simulate_truth(cfg, np.random.default_rng(seed))[:, 4]
        gone = np.flatnonzero(z == 0)
        assert 10 <= gone[0] <= 20 and gone[-1] == 28 and (z[:gone[0]] > 0).all() and (z[29:] > 0).all()


def test_matched_filter_detector_finds_a_bright_target_and_not_a_missing_one():
    from nnda.data.frames import FramesConfig, simulate
    from nnda.filters.tbd import TBDConfig, tbd_model
    from nnda.study.tbd_chain import frame_detections
    from nnda.study.tbd_runs import detector_counts

    def counts(fs):
        return detector_counts(fs.truth, frame_detections(tbd_model(fs, TBDConfig()), 1e-4), 5.0)

    scene = FramesConfig(rows=40, cols=40, frames=5)
    bright = counts(simulate(scene.model_copy(update={"ptcr_db": 20.0}), 4, 0))
    gone = counts(simulate(scene.model_copy(update={"ptcr_db": -400.0}), 4, 0))
    assert bright[1] == gone[1] == 20 and bright[0] >= 19 and gone[0] <= 1
    assert gone[2] / 20 < 1.0  # false detections per frame at pfa 1e-4 over 46 x 46 x 4 tests
