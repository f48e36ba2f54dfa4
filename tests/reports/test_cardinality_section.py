"""The report's target-count section on a tiny study with the PHD filters: its figure and tables render,
its numbers and sentences come from cardinality.parquet and summary.json, the PHD trackers are in every
table, and a study directory without the counts still gets a report."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pyarrow.parquet as pq
import pytest

from count_study import count_study
from nnda.reports.cardinality_section import comparisons, run_spread
from nnda.reports.study_figures import run_band
from nnda.reports.study_report import build_report, write_report
from nnda.reports.text_table import interval
from nnda.study.cardinality import CARDINALITY_FILE
from nnda.study.compare import compare
from nnda.study.config import load_study


@pytest.fixture(scope="module")
def phd_study(tmp_path_factory, pair_scenario):
    root = tmp_path_factory.mktemp("phd-study")
    (root / "pair.toml").write_text(pair_scenario)
    (root / "study.toml").write_text(count_study("pair.toml", runs=3, seed=4))
    compare(load_study(root / "study.toml"), root / "out", workers=1)
    write_report(root / "out")
    return root / "out"


def _section(md: str) -> str:
    start = md.index("\n## Target count over time\n")
    return md[start:md.index("\n## ", start + 1)]


def test_the_section_has_its_figure_and_tables(phd_study):
    md = (phd_study / "report.md").read_text()
    sec = _section(md)
    assert "![pair: estimated target count per scan" in sec
    assert (phd_study / "figures/target_count_pair.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (phd_study / "report.html").read_text()
    assert '<section id="cardinality"><h2>Target count over time</h2>' in page
    assert 'id="count-error"' in page and 'id="filter-cardinality"' in page
    summary = json.loads((phd_study / "summary.json").read_text())
    errors = summary["scenarios"][0]["trackers"]
    for label in ("gnn", "ekphd", "cphd"):  # the count-error table reads the registry's count_error
        e = errors[label]["metrics"]["count_error"]
        assert f"| {label} | {interval(e['mean'], e['ci_low'], e['ci_high'], '{:.2f}')} |" in sec
    assert "| pair: ekphd |" in sec and "(Poisson) |" in sec and "| pair: cphd |" in sec
    assert "| pair: gnn |" not in sec  # gnn keeps no cardinality of its own


def test_the_phd_trackers_are_in_every_table_that_lists_trackers(phd_study):
    md = (phd_study / "report.md").read_text()
    tables = re.findall(r"(?:^\|.*\|\n)+", md, flags=re.M)
    # every table listing trackers, but the life cycle's deletions (a PHD filter has no life cycle)
    listing = [t for t in tables if re.search(r"\bgnn\b", t) and "| unconfirmed |" not in t
               and not t.startswith("| Scenario |")]  # the best-per-scenario table lists the best two
    assert len(listing) >= 3  # trackers (setup), the scenario's results, the count error
    for t in listing:
        assert re.search(r"\bekphd\b", t) and re.search(r"\bcphd\b", t), t
    results = md[md.index("### pair:"):].split("\n\n")[1]
    for key in ("OSPA localisation part", "OSPA cardinality part", "GOSPA missed-target part",
                "GOSPA false-track part"):
        assert f"| {key}, mean over scans (m" in results


def test_the_comparison_is_computed_from_the_recorded_counts(phd_study):
    t = pq.read_table(phd_study / CARDINALITY_FILE).to_pydict()
    spread = {}
    for label in ("ekphd", "cphd"):
        rows = [i for i, k in enumerate(t["tracker"]) if k == label]
        est = np.array([t["filter_mean"][i] for i in rows]) - np.array([t["true_count"][i] for i in rows])
        spread[label] = float(np.mean(np.std(est, axis=0, ddof=1)))
    own = float(np.mean(np.sqrt([t["filter_variance"][i] for i, k in enumerate(t["tracker"]) if k == "cphd"])))
    sec = _section((phd_study / "report.md").read_text())
    line = next(x for x in sec.splitlines() if x.startswith("* **cphd against ekphd**"))
    assert f"standard deviation of {spread['cphd']:.2f} per scan" in line
    assert f"ekphd's by {spread['ekphd']:.2f}: {spread['cphd'] / spread['ekphd']:.2f} times" in line
    assert f"own standard deviation: {own:.2f} (cphd's cardinality distribution)" in line
    smaller = int(spread["cphd"] < spread["ekphd"])
    assert f"smaller in {smaller} of 1 scenario(s)" in line


def test_the_sentence_follows_the_numbers():
    def rows(a: float, b: float) -> dict:
        return {("X", "cphd"): {"spread": a, "own_sd": 0.5, "cardinalised": True},
                ("X", "ekphd"): {"spread": b, "own_sd": 2.0, "cardinalised": False}}
    stat = {"mean": 0.1, "ci_low": 0.05, "ci_high": 0.15, "n": 3}
    worse = {"mean": 0.4, "ci_low": 0.3, "ci_high": 0.5, "n": 3}
    summary = {"confidence": 0.95, "scenarios": [{"name": "X", "trackers": {
        "cphd": {"metrics": {"count_error": stat}}, "ekphd": {"metrics": {"count_error": worse}}}}]}
    steady = comparisons(rows(0.1, 0.4), summary)[0]
    assert "0.25 times ekphd's, smaller in 1 of 1" in steady and "0.25 times." in steady
    assert "cphd's below ekphd's in 1 of 1 scenario(s), with the 95% intervals apart in 1" in steady
    summary["scenarios"][0]["trackers"]["cphd"]["metrics"]["count_error"] = {**worse, "mean": 0.6, "ci_low": 0.55}
    loose = comparisons(rows(0.8, 0.4), summary)[0]
    assert "2.00 times ekphd's, smaller in 0 of 1" in loose and "below ekphd's in 0 of 1" in loose
    assert "no pair" in comparisons({("X", "cphd"): rows(0.1, 0.2)["X", "cphd"]}, summary)[0]
    nan = comparisons(rows(float("nan"), float("nan")), summary)[0]
    assert "needs at least two runs" in nan


def test_bands_and_spreads_over_runs():
    a = np.array([[1.0, 2.0, np.nan], [3.0, 2.0, np.nan], [2.0, 2.0, 4.0]])
    mean, low, high = run_band(a)
    np.testing.assert_allclose(mean, [2.0, 2.0, 4.0])
    np.testing.assert_allclose(low, [1.05, 2.0, 4.0]) and np.testing.assert_allclose(high, [2.95, 2.0, 4.0])
    assert run_spread(a, np.zeros_like(a)) == pytest.approx(0.5)  # sd 1, 0 and one run (undefined: left out)
    assert np.isnan(run_spread(a[:1], a[:1]))


def test_a_study_without_counts_still_gets_its_report(phd_study, tmp_path):
    old = tmp_path / "old"
    shutil.copytree(phd_study, old)
    (old / CARDINALITY_FILE).unlink()
    md, _, figures = build_report(old)
    sec = _section(md)
    assert f"no `{CARDINALITY_FILE}` (written before nnda recorded" in sec and "| ekphd |" in sec
    assert not any(f.name.startswith("target_count_") for f in figures)
