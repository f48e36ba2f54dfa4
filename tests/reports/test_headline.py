"""The report's opening: the Pareto marking on hand-made points, the quality-against-cost figure's
points read back from summary.json and timing.json, the compact table and the reading computed from the
numbers, and the per-scenario verdicts as one table."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from nnda.reports.headline import OVERALL, compact_table, headline_points, pareto_front, quality_cost, reading
from nnda.reports.study_summary import family_table, verdict_table
from nnda.study.measures import measure

LOWER, HIGHER = -1, +1


def test_pareto_front_on_hand_made_points_with_ties_and_duplicates():
    # (time, GOSPA): both lower is better
    points = [(1.0, 10.0),  # a: fastest -> front
              (2.0, 5.0),  # b: front
              (2.0, 5.0),  # c: a duplicate of b: neither dominates the other -> both front
              (3.0, 5.0),  # d: ties b on GOSPA, slower -> dominated
              (2.0, 7.0),  # e: ties b on time, worse GOSPA -> dominated
              (4.0, 1.0),  # f: best GOSPA -> front
              (5.0, 6.0),  # g: dominated by b
              (1.0, 10.0),  # h: a duplicate of a -> front
              (math.nan, 0.0)]  # i: undefined: never on the front, dominates nothing
    assert pareto_front(points, (LOWER, LOWER)).tolist() == [True, True, True, False, False, True, False, True,
                                                             False]
    # (time, hit rate): higher hit rate is better
    rates = [(1.0, 90.0), (2.0, 95.0), (2.0, 95.0), (3.0, 95.0), (0.5, 80.0), (4.0, 90.0)]
    assert pareto_front(rates, (LOWER, HIGHER)).tolist() == [True, True, True, False, True, False]
    assert pareto_front([(3.0, 3.0)], (LOWER, LOWER)).tolist() == [True]
    assert pareto_front(np.zeros((0, 2)), (LOWER, LOWER)).tolist() == []
    # all equal: nobody dominates
    assert pareto_front([(1.0, 1.0)] * 3, (LOWER, LOWER)).all()


def _files(study_dir) -> tuple[dict, dict]:
    return (json.loads((study_dir / "summary.json").read_text()),
            json.loads((study_dir / "timing.json").read_text()))


@pytest.mark.parametrize("key", ["gospa", "hit_rate"])
def test_the_figures_points_are_the_summarys_numbers(study_dir, key):
    summary, timing = _files(study_dir)
    panels = headline_points(summary, timing, key)
    names = [sc["name"] for sc in summary["scenarios"]]
    trackers = [t["label"] for t in summary["trackers"]]
    assert list(panels) == [OVERALL, *names]
    scale = measure(key).scale
    for sc, tsc in zip(summary["scenarios"], timing["scenarios"]):
        assert [p.tracker for p in panels[sc["name"]]] == trackers
        for p in panels[sc["name"]]:
            q, t = sc["trackers"][p.tracker]["metrics"][key], tsc["trackers"][p.tracker]["mean_time_per_scan_s"]
            assert (p.value, p.low, p.high) == (q["mean"] * scale, q["ci_low"] * scale, q["ci_high"] * scale)
            assert (p.time_ms, p.time_low, p.time_high) == pytest.approx((t["mean"] * 1e3, t["ci_low"] * 1e3,
                                                                          t["ci_high"] * 1e3))
    for p in panels[OVERALL]:  # the mean over scenarios of the per-scenario means; bounds: means of the bounds
        qs = [sc["trackers"][p.tracker]["metrics"][key] for sc in summary["scenarios"]]
        ts = [sc["trackers"][p.tracker]["mean_time_per_scan_s"] for sc in timing["scenarios"]]
        assert p.value == pytest.approx(np.mean([q["mean"] for q in qs]) * scale)
        assert p.low == pytest.approx(np.mean([q["ci_low"] for q in qs]) * scale)
        assert p.high == pytest.approx(np.mean([q["ci_high"] for q in qs]) * scale)
        assert p.time_ms == pytest.approx(np.mean([t["mean"] for t in ts]) * 1e3)


def test_the_figure_is_in_the_report_and_the_same_bytes_twice(study_dir):
    summary, timing = _files(study_dir)
    trackers = [t["label"] for t in summary["trackers"]]
    png = quality_cost(headline_points(summary, timing, "gospa"), "gospa", trackers)
    assert png == quality_cost(headline_points(summary, timing, "gospa"), "gospa", trackers)
    assert (study_dir / "figures/quality_cost_gospa.png").read_bytes() == png
    md = (study_dir / "report.md").read_text()
    summary_md = md[md.index("## Summary\n"):md.index("\n## Setup\n")]
    first = summary_md.index("![GOSPA against time per scan")
    assert first < summary_md.index("### Over all scenarios") < summary_md.index("### Best per scenario")
    assert "(figures/quality_cost_hit_rate.png)" in summary_md


def test_the_compact_table_reads_the_means_over_scenarios(study_dir):
    summary, timing = _files(study_dir)
    table = compact_table(summary, timing)
    trackers = [t["label"] for t in summary["trackers"]]
    assert [r[0] for r in table.rows] == trackers
    column = table.header.index("GOSPA, mean over scans (m)")
    means = {t: np.mean([sc["trackers"][t]["metrics"]["gospa"]["mean"] for sc in summary["scenarios"]])
             for t in trackers}
    wins = {t: sum(min(sc["trackers"], key=lambda u: sc["trackers"][u]["metrics"]["gospa"]["mean"]) == t
                   for sc in summary["scenarios"]) for t in trackers}
    best = min(means, key=means.get)
    for row in table.rows:
        t = row[0]
        text = f"{means[t]:.1f}"
        assert row[column] == (f"**{text}**" if t == best else text) + f" ({wins[t]})"
    md = (study_dir / "report.md").read_text()
    page = (study_dir / "report.html").read_text()
    assert table.markdown() in md
    assert f"<td><strong>{means[best]:.1f}</strong> ({wins[best]})</td>" in page and 'id="headline-table"' in page


def _stat(mean, low=None, high=None):
    return {"mean": mean, "ci_low": low, "ci_high": high, "n": 5}


def _study(gospa: dict, hit: dict, time: dict, kinds: dict) -> tuple[dict, dict]:
    """A hand-made summary and timing: per tracker, a list over scenarios of (mean, low, high)."""
    names = [f"S{i + 1}" for i in range(len(next(iter(gospa.values()))))]
    scenarios = [{"name": n, "trackers": {t: {"metrics": {"gospa": _stat(*gospa[t][i]), "hit_rate": _stat(*hit[t][i])},
                                              "runs": 5} for t in gospa}} for i, n in enumerate(names)]
    timing = [{"name": n, "trackers": {t: {"mean_time_per_scan_s": _stat(*time[t][i])} for t in gospa}}
              for i, n in enumerate(names)]
    return ({"confidence": 0.95, "trackers": [{"label": t, "kind": kinds[t]} for t in gospa], "scenarios": scenarios},
            {"scenarios": timing})


def test_the_reading_counts_the_wins_and_the_cost_and_names_the_fronts():
    summary, timing = _study(
        gospa={"mht": [(100, 90, 110), (200, 190, 210), (300, 250, 350)],
               "nn": [(150, 140, 160), (180, 150, 230), (360, 340, 420)],
               "phd": [(500, 480, 520), (600, 580, 620), (700, 680, 720)]},
        hit={"mht": [(95, 94, 96)] * 3, "nn": [(90, 88, 92)] * 3, "phd": [(None,)] * 3},
        time={"mht": [(3e-3, 2.9e-3, 3.1e-3)] * 3, "nn": [(1e-3, 0.9e-3, 1.1e-3)] * 3,
              "phd": [(2e-3, 1.9e-3, 2.1e-3)] * 3},
        kinds={"mht": "mht", "nn": "nn", "phd": "gmphd"})
    text = reading(summary, timing)
    assert text.startswith("**mht** has the lowest GOSPA in 2 of 3 scenario(s) (intervals apart in 1) at 3x the "
                           "time per scan of nn, the fastest. **mht** has the highest hit rate in 3 of 3 scenario(s) "
                           "(intervals apart in 3).")
    # over all: mht GOSPA 200 at 3 ms, nn 243 at 1 ms, phd 600 at 2 ms (dominated by nn); phd has no hit rate
    assert text.endswith("On the Pareto front over all scenarios (no tracker both faster and better), GOSPA against "
                         "time: mht, nn; Hit rate against time: mht, nn.")
    hit_points = headline_points(summary, timing, "hit_rate")
    assert [p.tracker for p in hit_points[OVERALL]] == ["mht", "nn"] and all(len(p) == 2 for p in
                                                                             hit_points.values())
    table = compact_table(summary, timing)
    rows = {r[0]: r for r in table.rows}
    hit_col = table.header.index("Hit rate (%)")
    assert rows["phd"][hit_col] == "—" and rows["mht"][hit_col] == "**95.00** (3)"
    assert rows["nn"][table.header.index("Time per scan, mean over scans (ms)")] == "**1** (3)"
    assert reading({**summary, "trackers": summary["trackers"][:1]}, timing).startswith("Only one tracker")


def test_the_verdicts_are_one_table_with_the_time_ratios():
    summary, timing = _study(
        gospa={"mht": [(100, 90, 110), (200, 190, 210)], "nn": [(150, 140, 160), (180, 150, 230)]},
        hit={"mht": [(95, 94, 96)] * 2, "nn": [(95, 94, 96)] * 2},
        time={"mht": [(4e-3, 3.9e-3, 4.1e-3)] * 2, "nn": [(1e-3, 0.9e-3, 1.1e-3)] * 2},
        kinds={"mht": "mht", "nn": "nn"})
    table = verdict_table(summary, timing)
    assert [r[0] for r in table.rows] == ["S1", "S2"]
    gospa = table.header.index("GOSPA, mean over scans (m)")
    assert table.rows[0][gospa] == "mht 100.0 [90.0, 110.0] m, clear of nn (150.0)"
    assert table.rows[1][gospa] == "nn 180.0 [150.0, 230.0] m, not separable at 95% from mht (200.0)"
    assert table.rows[0][table.header.index("Hit rate (%)")] == "all equal (95.00 [94.00, 96.00] %)"
    # S1 is a thesis scenario: its ratio stands beside the thesis's
    assert table.rows[0][-1].startswith("nn / mht = 0.250 (thesis: ")
    assert table.header[-1] == "Time per scan, neural / MHT"


def test_a_tracker_missing_from_a_scenario_has_no_point_there_nor_over_all():
    summary, timing = _study(
        gospa={"a": [(100, 90, 110), (200, 190, 210)], "b": [(150, 140, 160), (180, 150, 230)]},
        hit={"a": [(95, 94, 96)] * 2, "b": [(90, 89, 91)] * 2},
        time={"a": [(2e-3, 1.9e-3, 2.1e-3)] * 2, "b": [(1e-3, 0.9e-3, 1.1e-3)] * 2},
        kinds={"a": "gnn", "b": "gnn"})
    del summary["scenarios"][1]["trackers"]["b"], timing["scenarios"][1]["trackers"]["b"]
    panels = headline_points(summary, timing, "gospa")
    assert [[p.tracker for p in panels[k]] for k in (OVERALL, "S1", "S2")] == [["a"], ["a", "b"], ["a"]]
    table = compact_table(summary, timing)
    column = table.header.index("GOSPA, mean over scans (m)")
    assert {r[0]: r[column] for r in table.rows} == {"a": "150.0 (1)", "b": "—"}  # no best among one


def test_the_family_table_says_which_family_wins_where_and_its_cost():
    summary, timing = _study(
        gospa={"mht": [(100, 90, 110), (200, 190, 210), (300, 250, 350)],
               "pmbm": [(150, 140, 160), (180, 150, 230), (360, 340, 420)],
               "glmb": [(160, 150, 170), (190, 170, 210), (290, 280, 300)],
               "phd": [(500, 480, 520), (600, 580, 620), (700, 680, 720)]},
        hit={"mht": [(95, 94, 96)] * 3, "pmbm": [(96, 95, 97)] * 3, "glmb": [(90, 88, 92)] * 3,
             "phd": [(None,)] * 3},
        time={"mht": [(3e-3, 2.9e-3, 3.1e-3)] * 3, "pmbm": [(5e-3, 4.9e-3, 5.1e-3)] * 3,
              "glmb": [(2e-3, 1.9e-3, 2.1e-3)] * 3, "phd": [(1e-3, 0.9e-3, 1.1e-3)] * 3},
        kinds={"mht": "mht", "pmbm": "pmbm", "glmb": "glmb", "phd": "gmphd"})
    table = family_table(summary, timing)
    rows = {r[0]: r for r in table.rows}
    assert list(rows) == ["multiple hypothesis tracking", "multi-Bernoulli mixtures (PMBM, GLMB, LMB)",
                          "PHD filters (no association)"]
    rfs = rows["multi-Bernoulli mixtures (PMBM, GLMB, LMB)"]
    assert rfs[1] == "pmbm, glmb"
    # GOSPA: mht wins S1, pmbm S2, glmb S3 (two members, one family); hit rate: pmbm everywhere
    assert rfs[2:4] == ("2: S2, S3", "3: S1, S2, S3")
    assert rows["multiple hypothesis tracking"][2:4] == ("1: S1", "0")
    assert rfs[-1] == "2-5" and rows["PHD filters (no association)"][-1] == "1-1"
    assert table.header[2:4] == ("Best GOSPA in", "Best hit rate in")
    # one family: no table
    one = {**summary, "trackers": [t for t in summary["trackers"] if t["kind"] in ("pmbm", "glmb")]}
    assert family_table(one, timing) is None
