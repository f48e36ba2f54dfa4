"""The detect-then-track chain of seed 003: its parameters against their definitions, the chain on an easy
sequence and on target-free frames, the study's chain entries, and the report's chain rows and verdict read
from the numbers."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from kind_study import run_kind
from nnda.data import gmrf
from nnda.data.frames import FramesConfig, simulate
from nnda.errors import ConfigError, validated
from nnda.filters.tbd import TBDConfig, TBDModel, tbd_model
from nnda.reports.tbd_section import _chain_verdicts, _divergence_table, _pairs_table
from nnda.study.tbd import TBDStudyConfig, score
from nnda.study.tbd_chain import (
    COAST_RISK,
    ChainConfig,
    detection_probability,
    frame_detections,
    run_chain,
    track_filter,
    tracker_params,
)

#: small frames: 48 x 48, 15 frames; acquisition frames left out of the rates
SCENE = FramesConfig(rows=48, cols=48, frames=15)
RUNS, ACQUISITION, PFA = 8, 5, 1e-4


def test_params_follow_the_frame_model_and_the_detector():
    cfg = ChainConfig()
    for pd in (0.2, 0.43, 0.69, 0.95):
        p = tracker_params("mht", SCENE, cfg, 4, PFA, pd)
        j = 1
        while (1 - pd) ** j > COAST_RISK:  # the fewest misses in a row a detected target rarely has
            j += 1
        assert p["lifecycle"]["max_misses"] == j and p["pd"] == pd
        assert p["clutter_density"] == pytest.approx(4 * PFA, rel=1e-9)
        assert p["lifecycle"]["v_max"] == pytest.approx(cfg.speed_sds * SCENE.birth_velocity_sd, rel=1e-9)
    assert "clutter_density" not in tracker_params("gnn", SCENE, cfg, 4, PFA, 0.5)
    cv = track_filter(SCENE, cfg).models[0]
    assert cv.sigma_q**2 * SCENE.dt**2 == pytest.approx(SCENE.q * SCENE.dt, rel=1e-9)  # the velocity increment
    over = ChainConfig(params={"gnn": {"gate": 16.0, "lifecycle": {"m": 3}}})
    p = tracker_params("gnn", SCENE, over, 4, PFA, 0.5)
    assert p["gate"] == 16.0 and p["lifecycle"]["m"] == 3 and p["lifecycle"]["v_min"] == 0.0


def test_detection_probability_matches_the_detector_at_the_target():
    """The matched filter's P_D at the target's own pixel and aspect against the share of frames whose
    statistic there passes the threshold (2,000 frames)."""
    from scipy.special import ndtri

    fs = simulate(SCENE.model_copy(update={"ptcr_db": 6.5, "frames": 20, "aspects": SCENE.aspects[:1]}), 100, 3)
    model = tbd_model(fs, TBDConfig())
    lik, h = model.likelihood, SCENE.template_half
    passed = []
    for k in range(1, fs.steps + 1):
        t = lik.matched_filter(*model.frame_data(k))[:, 0]
        on = fs.truth[:, k - 1, 4] > 0
        r = np.rint(fs.truth[on, k - 1, 0]).astype(int) + h
        c = np.rint(fs.truth[on, k - 1, 2]).astype(int) + h
        passed += (t[np.flatnonzero(on), r, c] >= ndtri(1 - PFA)).tolist()
    pd = detection_probability(lik, fs.config, PFA)
    assert 0.2 < pd < 0.8 and np.mean(passed) == pytest.approx(pd, abs=0.04)


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_chain_tracks_a_bright_target(name):
    fs = simulate(SCENE.model_copy(update={"ptcr_db": 14.0}), RUNS, 1)
    model = tbd_model(fs, TBDConfig())
    out = run_chain(model, frame_detections(model, PFA), name, ChainConfig(), PFA)
    on = fs.truth[:, ACQUISITION:, 4] > 0
    assert on.mean() > 0.9 and out.present[:, ACQUISITION:][on].mean() >= 0.95
    err = np.hypot(*(out.position - fs.truth[..., [0, 2]]).transpose(2, 0, 1))[:, ACQUISITION:][on]
    assert np.sqrt(np.mean(err**2)) < 1.0  # pixels; the detections' own noise is ~0.8 px per axis
    assert out.tracks.max() <= 2 and out.settings["params"]["lifecycle"]["max_misses"] == 1


@pytest.mark.parametrize("name", ["gnn", "mht"])
def test_chain_rarely_declares_a_target_in_target_free_frames(name):
    """At most 5% of target-free frames after a 3-frame burn-in have a confirmed track (at 6.5 dB's
    settings, the longest coast; measured 0%)."""
    fs = simulate(SCENE.model_copy(update={"ptcr_db": 6.5}), 1, 0)
    V = gmrf.sample(SCENE.shape, SCENE.beta_h, SCENE.beta_v, SCENE.sigma_c, np.random.default_rng(4), (30, 15))
    model = TBDModel(V, fs.templates, fs.config, TBDConfig())
    hits = frame_detections(model, PFA)
    assert sum(len(h) for h in hits) > 30  # there is clutter to track
    out = run_chain(model, hits, name, ChainConfig(), PFA)
    assert out.present[:, 3:].mean() <= 0.05


def test_frames_without_an_estimate_are_lost_and_left_out_of_the_errors():
    """A NaN position (the chain without a confirmed track) is a lost frame, and the RMSE and steady error are
    over the frames with a position (brute force)."""
    rng = np.random.default_rng(2)
    R, K = 30, 8
    cfg = TBDStudyConfig(scene={"frames": K}, divergence_frames=3, steady_frames=4, acquisition=2)
    truth = np.zeros((R, K, 5))
    truth[..., 0], truth[..., 2], truth[..., 4] = rng.uniform(10, 100, (R, K)), rng.uniform(10, 100, (R, K)), 1
    position = truth[..., [0, 2]] + rng.normal(0, 2, (R, K, 2))
    present = rng.random((R, K)) < 0.7
    position[~present] = np.nan
    s = score(truth, position, present, cfg)
    err = np.hypot(*(position - truth[..., [0, 2]]).transpose(2, 0, 1))
    lost = ~present | (err > 5.0)  # NaN > 5 is False: ~present covers it
    diverged = lost[:, -3:].all(axis=1)
    assert s["diverged_runs"] == np.flatnonzero(diverged).tolist()
    for k in range(K):
        keep = present[:, k] & ~diverged
        want = np.sqrt(np.mean(err[keep, k] ** 2)) if keep.any() else None
        assert s["rmse"]["position"][k] == (None if want is None else pytest.approx(want, rel=1e-9))
    per_run = [np.mean(err[r, -4:][present[r, -4:]]) for r in range(R) if present[r, -4:].any()]
    assert s["steady_error_all"]["mean"] == pytest.approx(np.mean(per_run), rel=1e-9)


def test_bad_chain_config_is_a_config_error():
    with pytest.raises(ConfigError, match="unknown chain tracker 'jpda'"):
        validated(TBDStudyConfig, {"chain": {"trackers": ["gnn", "jpda"]}}, "test", "tbd study")
    with pytest.raises(ConfigError, match="names a tracker twice"):
        validated(TBDStudyConfig, {"chain": {"trackers": ["gnn", "gnn"]}}, "test", "tbd study")
    with pytest.raises(ConfigError, match="gate"):
        model = tbd_model(simulate(SCENE, 1, 0), TBDConfig())
        run_chain(model, frame_detections(model, PFA), "gnn", ChainConfig(params={"gnn": {"gate": -1}}), PFA)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    cfg = {"runs": 4, "chunk_runs": 3, "ptcr_db": (6.5, 8.1), "scene": {"rows": 40, "cols": 40, "frames": 8},
           "filters": [{"name": "apf", "particles": 300}], "divergence_frames": 2, "steady_frames": 3,
           "acquisition": 2, "exit_reentry": {"runs": 2, "frames": 16, "exit_frames": 4, "reentry_frame": 10}}
    return run_kind(tmp_path_factory.mktemp("chain") / "out", "tbd", cfg)


def test_study_scores_the_chain_as_the_filters(small):
    s = small["settings"][0]
    assert list(s["chain"]) == ["gnn", "mht"] and len(s["chain_vs_filters"]) == 2
    gnn = s["chain"]["gnn"]
    assert gnn["divergence"]["runs"] == 4 and len(gnn["rmse"]["x"]) == 8 and gnn["ms_per_frame"] > 0
    assert s["detector"]["correlations_per_frame"] == 4 * 46 * 46
    assert set(small["exit_reentry"]["chain"]) == {"gnn", "mht"}
    # the chain's entry is `score` of its own decisions: rerun it on the same frames
    cfg = validated(TBDStudyConfig, small["config"], "test", "tbd study")
    scene = cfg.scene.model_copy(update={"ptcr_db": 6.5})
    parts = []
    for start in (0, 3):  # the study's chunks
        fs = simulate(scene, min(3, 4 - start), cfg.seed, first_run=start)
        model = tbd_model(fs, cfg.tbd)
        parts.append((fs.truth, run_chain(model, frame_detections(model, PFA), "gnn", cfg.chain, PFA)))
    truth = np.concatenate([t for t, _ in parts])
    mine = score(truth, np.concatenate([o.position for _, o in parts]),
                 np.concatenate([o.present for _, o in parts]), cfg)
    assert mine["divergence"] == gnn["divergence"] and mine["declared_present"] == gnn["declared_present"]


def test_report_rows_and_verdict_move_with_the_numbers(small):
    s = copy.deepcopy(small["settings"][0])
    row = lambda table: next(r for r in table.rows if r[0] == "detect + gnn")  # noqa: E731
    before = row(_divergence_table(s, 0.95))
    s["chain"]["gnn"]["divergence"] |= {"count": 3, "rate": 0.75, "ci_low": 0.19, "ci_high": 0.99}
    s["chain"]["gnn"]["declared_present"] = 0.125
    after = row(_divergence_table(s, 0.95))
    assert after != before and after[1] == "3/4" and after[5] == "12.5%"
    pair = next(r for r in _pairs_table(s, 0.95).rows if r[0] == "detect + gnn vs apf@300")
    assert pair[1].startswith("3 vs ")
    settings = copy.deepcopy(small["settings"])
    for sign, word in ((-1, "fewer"), (1, "more")):
        for st in settings:
            vs = next(v for v in st["chain_vs_filters"] if v["chain"] == "gnn")
            vs["present_difference"] = {"mean": sign * 0.25, "ci_low": sign * 0.25 - 0.05,
                                        "ci_high": sign * 0.25 + 0.05, "n": 4}
        text = _chain_verdicts(settings)[0]
        assert f"25.0 points {word} at 6.5 dB" in text and "significant" in text and "covers 0" not in text
    assert math.isfinite(small["runtime_s"])


def test_no_chain_flag_runs_the_detector_alone(tmp_path):
    import json

    from nnda.app.study_commands import tbd

    (tmp_path / "tiny.toml").write_text('runs = 2\nptcr_db = [8.1]\nscene = {rows = 32, cols = 32, frames = 5}\n'
                                        'filters = [{name = "apf", particles = 200}]\nexit_reentry = {runs = 1, '
                                        'frames = 12, exit_frames = 3, reentry_frame = 8}\ndivergence_frames = 2\n'
                                        'steady_frames = 2\nacquisition = 2\n')
    tbd(out=tmp_path / "t", config=tmp_path / "tiny.toml", chain=False)
    results = json.loads((tmp_path / "t" / "summary.json").read_text())["tbd"]
    assert results["config"]["chain"] is None and results["settings"][0]["chain"] == {}
    md = (tmp_path / "t" / "report.md").read_text()
    assert "were not tracked" in md and "detect + gnn" not in md
