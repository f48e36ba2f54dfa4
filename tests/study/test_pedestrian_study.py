"""The pedestrian study (Frencl 2014): estimate ownership, the thesis's RMS figures, the tables, verdicts, command."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from nnda.app.cli import app
from nnda.data.pedestrian.walkers import walker_runs
from nnda.reports import pedestrian_section as ps
from nnda.reports.pedestrian_values import THESIS_EXCESS, THESIS_RMS, THESIS_RUNTIME_S
from nnda.study import pedestrian as P
from nnda.study import pedestrian_scores as S
from nnda.study.timing import join_timing, split_timing


def _trace(truth_scan, truth_xy, est_scan, est_xy, k):
    return S.Trace(np.array(truth_scan), np.array(truth_xy, float).reshape(-1, 2), np.array(est_scan, np.int64),
                   np.array(est_xy, float).reshape(-1, 2), np.zeros(k, int), np.zeros(k), 0.0)


def _owned_by_brute_force(t: S.Trace, n_scans: int, c: float):
    """Every estimate against every true point of its scan, one at a time."""
    M = len(t.truth_scan)
    count = np.zeros(M, int)
    close_x, all_x, found = np.zeros(n_scans), np.zeros(n_scans), np.zeros(n_scans)
    best = {}
    for e, (s, xy) in enumerate(zip(t.est_scan, t.est_xy, strict=True)):
        rows = [m for m in range(M) if t.truth_scan[m] == s]
        if not rows:
            continue
        d = [math.dist(xy, t.truth_xy[m]) for m in rows]
        m = rows[int(np.argmin(d))]
        if min(d) < c:
            count[m] += 1
            all_x[s - 1] += (xy[0] - t.truth_xy[m, 0]) ** 2
            if m not in best or min(d) < best[m][0]:
                best[m] = (min(d), (xy[0] - t.truth_xy[m, 0]) ** 2)
    for m, (_, sq) in best.items():
        close_x[t.truth_scan[m] - 1] += sq
        found[t.truth_scan[m] - 1] += 1
    return count, close_x, all_x, found


def test_estimates_go_to_the_nearest_true_point_within_the_cutoff():
    rng = np.random.default_rng(4)
    K = 6
    truth_scan = np.repeat(np.arange(1, K + 1), 2)
    truth_xy = rng.uniform(0, 6, (2 * K, 2))
    est_scan = np.sort(rng.integers(1, K + 1, 30))
    est_xy = truth_xy[2 * (est_scan - 1)] + rng.normal(0, 1.5, (30, 2))
    t = _trace(truth_scan, truth_xy, est_scan, est_xy, K)
    o = S.owned(t, K, 2.0)
    count, close_x, all_x, found = _owned_by_brute_force(t, K, 2.0)
    np.testing.assert_array_equal(o.count, count)
    np.testing.assert_allclose(o.close_x, close_x, rtol=1e-12)
    np.testing.assert_allclose(o.all_x, all_x, rtol=1e-12)
    np.testing.assert_array_equal(o.found, found)
    np.testing.assert_array_equal(o.points, np.full(K, 2))


def _score(cfg: P.PedestrianStudyConfig, traces: dict) -> dict:
    runs = {label: [S.score_run(t, 60, cfg.cutoff_m) for t in ts] for label, ts in traces.items()}
    return S.score_accuracy(runs, 60, cfg.seed, cfg.bootstrap, cfg.confidence, 0)


@pytest.fixture(scope="module")
def test4():
    """Test 4 on 3 runs (both filters), its traces and its scores."""
    cfg = P.PedestrianStudyConfig(tests=("test4",), test4_runs=3, bootstrap=200)
    spec = P.TEST_SPECS["test4"]
    scene = P.PEDESTRIAN_SCENES[spec.accuracy]
    datasets = list(walker_runs(scene, range(3), cfg.seed))
    traces = {f.label: [P.track(f, scene, ds, cfg.birth) for ds in datasets] for f in spec.filters}
    return cfg, traces, _score(cfg, traces)


def test_the_mean_rms_is_the_thesis_min_distance_rms_from_the_runs(test4):
    cfg, traces, acc = test4
    for label, ts in traces.items():
        per = [_owned_by_brute_force(t, 60, cfg.cutoff_m) for t in ts]
        close = np.array([p[1] for p in per])
        found = np.array([p[3] for p in per])
        with np.errstate(invalid="ignore"):
            rms_k = np.sqrt(close.sum(axis=0) / found.sum(axis=0))
        assert acc["filters"][label]["mean_rms"]["x"]["mean"] == pytest.approx(np.nanmean(rms_k), rel=1e-9)
        s = acc["filters"][label]["mean_rms"]["x"]
        assert s["ci_low"] <= s["mean"] <= s["ci_high"]


def test_changing_one_run_moves_the_table(test4):
    cfg, traces, acc = test4
    label = next(iter(traces))
    moved = dict(traces)
    t = moved[label][1]
    moved[label] = [traces[label][0], dataclasses.replace(t, est_xy=t.est_xy + [0.5, 0.0]), *traces[label][2:]]
    again = _score(cfg, moved)
    assert again["filters"][label]["mean_rms"]["x"]["mean"] > acc["filters"][label]["mean_rms"]["x"]["mean"]
    assert again["filters"][label]["mean_rms"]["y"] == acc["filters"][label]["mean_rms"]["y"]
    test = {"name": "test4", "title": "Test 4", "accuracy_scene": "walk-test4"}
    before = ps.accuracy_table({**test, "accuracy": acc}).rows[0]
    after = ps.accuracy_table({**test, "accuracy": again}).rows[0]
    assert before[2] != after[2] and before[4] == after[4]


def test_a_block_of_runs_is_the_same_alone_as_among_all_runs(test4):
    cfg, traces, _ = test4
    f = P.TEST_SPECS["test4"].filters[0]
    whole = P.run_block("walk-test4", f, 0, 3, cfg.seed, cfg.birth, cfg.cutoff_m, True)
    split = [*P.run_block("walk-test4", f, 0, 1, cfg.seed, cfg.birth, cfg.cutoff_m, True),
             *P.run_block("walk-test4", f, 1, 2, cfg.seed, cfg.birth, cfg.cutoff_m, True)]
    for a, b, t in zip(whole, split, traces[f.label], strict=True):
        assert {k: v for k, v in a.items() if k != "timing"} == {k: v for k, v in b.items() if k != "timing"}
        assert a["estimates"] == t.est_xy.tolist() and a["weight"] == t.weight.tolist()


def test_oracle_birth_puts_the_thesis_components_on_the_true_first_states():
    from nnda.data.pedestrian.walkers import generate_walkers

    scene = P.PEDESTRIAN_SCENES["walk-test2"]
    ds = generate_walkers(scene)
    for f in P.TEST_SPECS["test2"].filters:
        params = P.filter_params(f, scene, "oracle", ds)
        (c,) = params["birth"]["components"]
        first = ds.truth.scan == ds.truth.scan.min()
        assert params["birth"]["every_scan"] is False and c["weight"] == P.BIRTH_WEIGHT
        xy = (c["mean"][0], c["mean"][1] if f.motion in P.HEADING else c["mean"][2])
        assert xy == (ds.truth.x[first][0], ds.truth.y[first][0])
        assert params["clutter_area_m2"] == 2500.0 and params["clutter"] == pytest.approx(5.0)


def _stat(low, high):
    return {"mean": (low + high) / 2, "ci_low": low, "ci_high": high}


def test_a_claim_holds_fails_or_is_not_shown_by_its_intervals():
    assert "**holds**" in ps._claim("c", [_stat(-2, -1), _stat(-3, -0.1)], -1)
    assert "**fails**" in ps._claim("c", [_stat(-2, -1), _stat(0.1, 1)], -1)
    assert "**not shown**" in ps._claim("c", [_stat(-2, -1), _stat(-1, 1)], -1)


def test_the_thesis_values_name_the_studys_filters():
    for table in (THESIS_RMS, THESIS_RUNTIME_S):
        for test, values in table.items():
            assert set(values) == {f.label for f in P.TEST_SPECS[test].filters}
    assert set(THESIS_EXCESS) == {f.label for f in P.TEST_SPECS["test4"].filters}


def test_the_command_writes_results_and_a_report(tmp_path):
    out = tmp_path / "ped"
    args = ["pedestrian", "test4", "--out", str(out), "--test4-runs", "2", "--no-beyond"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    results = json.loads((out / "summary.json").read_text())["pedestrian"]
    assert [t["name"] for t in results["tests"]] == ["test4"]
    md = (out / "report.md").read_text()
    assert "19800" in md and "the HM map gives fewer duplicate estimates" in md
    assert (out / "figures" / "pedestrian-test4-density.png").stat().st_size > 1000
    again = CliRunner().invoke(app, args)
    assert again.exit_code != 0 and "already exists" in str(again.exception or again.output)
    second = tmp_path / "again"
    assert CliRunner().invoke(app, [*args[:3], str(second), *args[4:]]).exit_code == 0
    assert (second / "summary.json").read_bytes() == (out / "summary.json").read_bytes()  # same seed, same bytes
    assert "runtime_s" in json.loads((out / "timing.json").read_text())["pedestrian"] and "runtime_s" not in results


def test_the_wall_clock_entries_split_off_and_join_back():
    doc = {"a": 1, "runtime_s": 2.0, "tests": [{"x": [1, 2], "per_run": {"time_per_scan_s": {"mean": 1.0}}},
                                               {"y": 3}]}
    kept, timing = split_timing(doc)
    assert "runtime_s" not in json.dumps(kept) and "time_per_scan_s" not in json.dumps(kept)
    assert timing == {"runtime_s": 2.0, "tests": [{"per_run": {"time_per_scan_s": {"mean": 1.0}}}, {}]}
    assert join_timing(kept, timing) == doc


def test_the_command_refuses_an_unknown_test(tmp_path):
    result = CliRunner().invoke(app, ["pedestrian", "test9", "--out", str(tmp_path / "x")])
    assert result.exit_code != 0
    assert "test9" in str(result.exception) + result.output and not (tmp_path / "x").exists()


def test_the_contact_trackers_follow_the_walkers_with_the_thesis_cv():
    """Beyond the thesis: GNN, JPDA and MHT with the thesis's CV as a one-model IMM on the stress scene."""
    scene = P.PEDESTRIAN_SCENES[P.BEYOND_SCENE]
    ds = next(walker_runs(scene, [0]))
    for f in P.BEYOND[3:]:
        tracker = P.contact_tracker(f, scene, ds.scenario.sensors)
        assert tracker.filter.models[0].__class__.__name__ == "DiagonalCV"
    runs = {"GNN": P.run_block(P.BEYOND_SCENE, P.BEYOND[3], 0, 1, 0, "measurement", 2.0, False)}
    stress = S.score_stress(runs, scene.n_scans, 0.95)
    assert stress["filters"]["GNN"]["per_run"]["ospa"]["mean"] < 1.5
    table = ps.beyond_table({"scene": P.BEYOND_SCENE, **stress})
    assert [r[0] for r in table.rows] == ["GNN"]


def test_test1_draws_match_the_closed_form_variances_and_make_the_figures(tmp_path):
    out = tmp_path / "t1"
    result = CliRunner().invoke(app, ["pedestrian", "test1", "--out", str(out), "--no-beyond"])
    assert result.exit_code == 0, result.output
    results = json.loads((out / "summary.json").read_text())["pedestrian"]
    assert results["tests"] == [] and "beyond" not in results
    leaf7 = next(e for e in results["test1"]["variance"]["leaf"] if e["parameter"] == 7.0)
    assert leaf7["closed"] == pytest.approx(0.0408, abs=5e-5)
    inside = [e["sampled"]["ci_low"] <= e["closed"] <= e["sampled"]["ci_high"]
              for entries in results["test1"]["variance"].values() for e in entries]
    assert sum(inside) >= len(inside) - 2  # 95% intervals: a miss or two among 24 is chance
    assert [sum(h["counts"]) for h in results["test1"]["histograms"]] == [S.TEST1_DRAWS] * 3
    assert (out / "figures" / "pedestrian-test1-profiles.png").stat().st_size > 10_000
    assert "Test 1: variance of the heading deviation" in (out / "report.md").read_text()


def test_a_bad_study_config_is_refused_naming_the_file_and_field(tmp_path):
    config = tmp_path / "ped.toml"
    config.write_text('runs = 1\nbirth = "psychic"\n')
    result = CliRunner().invoke(app, ["pedestrian", "--config", str(config), "--out", str(tmp_path / "o")])
    message = str(result.exception)
    assert result.exit_code != 0 and str(config) in message and "runs" in message and "birth" in message
    assert not (tmp_path / "o").exists()


def test_the_command_knows_the_studys_tests():
    from nnda.app.study_commands import PEDESTRIAN_TESTS

    assert PEDESTRIAN_TESTS == P.TESTS  # the command's own copy, kept so that `nnda --help` loads no tracker
