"""The study report: every section, the thesis's columns where they belong, the classifier figures
recomputed from the model's own training data, a rebuild from saved results, the summary's verdicts."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.errors import DatasetError
from nnda.models.metrics import classifier_metrics
from nnda.models.pairs import pairs_from_datasets
from nnda.models.scorer import load_model
from nnda.reports.pages import markdown_page
from nnda.reports.study_report import build_report, report_sections
from nnda.reports.study_summary import verdicts
from nnda.reports.trajectory_plot import plotly_js
from nnda.study.checksums import write_checksums

SECTIONS = {"summary": "Summary", "setup": "Setup", "classifier": "Association network",
            "scenarios": "Results per scenario", "timing": "Time per scan",
            "over-time": "False tracks and GOSPA over time", "cardinality": "Target count over time",
            "trajectories": "Trajectories and tracks"}


def test_markdown_and_html_hold_every_section_and_figure(study_dir):
    md = (study_dir / "report.md").read_text()
    page = (study_dir / "report.html").read_text()
    for ident, title in SECTIONS.items():
        assert f"\n## {title}\n" in md
        assert f'<section id="{ident}"><h2>{title}</h2>' in page
    figures = re.findall(r"\]\((figures/[^)]+\.png)\)", md)
    # quality against cost (GOSPA, hit rate), ROC, time per scan; over time and target count per scenario (the
    # trajectories are drawn once, interactive, in report.html)
    assert len(figures) == 2 + 1 + 1 + 2 + 2
    for f in figures:
        assert (study_dir / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # self-contained: images inline, plotly.js inline, nothing fetched
    body = page[page.index("<body>"):]  # (plotly.js itself mentions data URIs)
    assert body.count('<img alt="') == body.count('src="data:image/png;base64,') == 2 + 1 + 1 + 2 + 2
    assert page.count(plotly_js()) == 1
    ours = page.replace(plotly_js(), "")
    assert not re.search(r"<(script|link|img)[^>]*\b(src|href)=\"(http|//)", ours) and "cdn." not in ours.lower()
    for scenario in ("pair", "S4"):
        assert f'id="trajectories-{scenario}"' in page and f'id="table-{scenario}"' in page


def test_thesis_columns_only_beside_the_thesis_scenario(study_dir):
    md = (study_dir / "report.md").read_text()
    s4 = md[md.index("### S4:"):].split("\n\n")[1]
    pair = md[md.index("### pair:"):].split("\n\n")[1]
    # trackers in the study's order (gnn-tight first), then the thesis's two columns
    thesis = "Vargas Avila (2015)"
    assert s4.splitlines()[0] == f"| Measure | gnn-tight | gnn | {thesis}: IMM/TOMHT | {thesis}: neural |"
    assert "| Target contacts |" in s4 and " 201.0 | 201.0 |" in s4  # Table 6.7's contact counts
    assert "Vargas Avila" not in pair.splitlines()[0] and "thesis" not in pair.splitlines()[0]


def test_classifier_figures_come_from_the_models_own_training_data(study_dir):
    saved = json.loads((study_dir / "classifier.json").read_text())["models"][0]
    model = load_model(study_dir.parent / "model")
    trained_on = model.metadata["dataset_names"]
    assert trained_on == ["train08/run-0/seed-8", "train09/run-0/seed-9"]
    datasets = [generate(preset("train08"), 8, 0), generate(preset("train09"), 9, 0)]
    pairs = pairs_from_datasets(datasets, **model.metadata["pair_options"])
    scores = model(pairs.features)
    expected = classifier_metrics(pairs.labels, scores)
    got = saved["evaluation"]["metrics"]
    assert (got["tp"], got["fn"], got["tn"], got["fp"]) == (expected.tp, expected.fn, expected.tn, expected.fp)
    assert got["auc"] == pytest.approx(expected.auc)
    assert saved["evaluation"]["n_pairs"] == len(pairs)
    assert "regenerated (2 datasets)" in saved["evaluation"]["pairs_from"]
    md = (study_dir / "report.md").read_text()
    assert f"| TP | {expected.tp} | 784 | 824 |" in md  # beside the thesis's GD and LM totals
    assert "| Epochs (best) | 12 (6) | 1000 | 35 |" in md


def test_nnda_report_rebuilds_the_same_report(study_dir, tmp_path):
    before = (study_dir / "report.md").read_text()
    (study_dir / "report.md").unlink()
    run = subprocess.run([sys.executable, "-m", "nnda", "report", str(study_dir)], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    assert "report.html" in run.stdout
    assert (study_dir / "report.md").read_text() == before


def test_an_unfinished_study_has_no_report(study_dir, tmp_path):
    (tmp_path / "study.json").write_bytes((study_dir / "study.json").read_bytes())
    with pytest.raises(DatasetError, match=r"summary.json: missing"):
        build_report(tmp_path)


def _summary(stats: dict[str, tuple], confidence=0.95) -> tuple[dict, dict]:
    """A one-scenario summary whose trackers have the given (mean, low, high) GOSPA."""
    trackers = {t: {"metrics": {"gospa": {"mean": m, "ci_low": lo, "ci_high": hi, "n": 5}}}
                for t, (m, lo, hi) in stats.items()}
    timing = {t: {"mean_time_per_scan_s": {"mean": None}} for t in stats}
    return ({"confidence": confidence, "trackers": [{"label": t, "kind": "gnn"} for t in stats],
             "scenarios": [{"name": "X", "trackers": trackers}]},
            {"scenarios": [{"name": "X", "trackers": timing}]})


def test_summary_calls_a_win_clear_only_when_the_intervals_are_apart():
    clear = verdicts(*_summary({"a": (100.0, 90.0, 110.0), "b": (150.0, 120.0, 180.0)}))[0]
    assert (clear.best, clear.second, clear.clear) == ("a", "b", True)
    assert clear.text == "a 100.0 [90.0, 110.0] m, clear of b (150.0)"
    close = verdicts(*_summary({"a": (130.0, 100.0, 160.0), "b": (120.0, 90.0, 150.0)}))[0]
    assert (close.best, close.clear) == ("b", False)
    assert close.text == "b 120.0 [90.0, 150.0] m, not separable at 95% from a (130.0)"
    tie = verdicts(*_summary({"a": (5.0, 5.0, 5.0), "b": (5.0, 5.0, 5.0), "c": (9.0, 9.0, 9.0)}))[0]
    assert tie.best is None and tie.text == "tie: a, b (5.0 m)"


def _ablation_doc(seed_measured: float, seed_true: float, extended: float, auc: float) -> dict:
    """An ablation.json with two variants under both data models; every seed scores the given accuracy."""
    def variant(history, name, acc):
        runs = [{"method": "lm", "seed": s, "metrics": {"test": {"accuracy": acc + 0.001 * s, "auc": auc}}}
                for s in range(3)]
        return {"history": history, "variant": name, "features": ["a"] * (3 if name == "seed" else 9), "runs": runs,
                "roc": {"fpr": [0.0, 0.5, 1.0], "tpr": {"lm": [0.0, 0.9, 1.0]}}}
    return {"format": "nnda.ablation", "format_version": 1, "methods": ["lm"],
            "pairs": {"measured": {"pairs": 1000, "negative_in_gate": 40, "negative_in_gate_fraction_of_pairs": 0.04,
                                   "own_outside_gate": 3}},
            "results": [variant("measured", "seed", seed_measured), variant("measured", "extended", extended),
                        variant("true", "seed", seed_true), variant("true", "extended", extended)]}


def test_the_ablation_section_reads_its_numbers(study_dir, tmp_path):
    import shutil

    from nnda.files import write_json

    copy = tmp_path / "out"
    shutil.copytree(study_dir, copy)
    assert "Feature ablation" not in (study_dir / "report.md").read_text()  # the fixture's, before the ablation
    sums = json.loads((copy / "checksums.json").read_text())

    def ablation(doc: dict) -> None:  # as a study naming that ablation writes it
        write_json(copy / "ablation.json", doc)
        write_checksums(copy, [*sums["sha256"], "ablation.json"], sums["fingerprint"])

    ablation(_ablation_doc(0.94, 0.985, 0.97, 0.993))
    md, page, figures = build_report(copy)
    assert "## Feature ablation" in md and 'id="ablation"' in page
    assert "nearer the **true**-history figure: it fits an error-free track history" in md
    assert "is **not met**: 40 of the 1000 pairs (4.0 %) are negatives inside" in md
    assert any(f.name == "ablation_roc.png" for f in figures)
    ablation(_ablation_doc(0.991, 0.999, 0.995, 0.999))
    md = markdown_page(*report_sections(copy)[:2])  # the text alone: the figures were drawn above
    assert "nearer the **measured**-history figure." in md and "is **met**." in md


def test_extended_and_seed_feature_trackers_are_compared_cell_by_cell():
    from nnda.reports.features_section import comparison, feature_pairs

    manifest = {"trackers": [{"label": "nn-seed", "kind": "nn", "model": "lm"},
                             {"label": "nn-gd", "kind": "nn", "model": "gd"},
                             {"label": "nn-ext", "kind": "nn", "model": "ext"},
                             {"label": "gnn", "kind": "gnn", "model": None}]}
    classifier = {"models": [{"label": "lm", "method": "lm", "features": "kinematic-3"},
                             {"label": "gd", "method": "gd"},
                             {"label": "ext", "method": "lm", "features": "imm-innovation-9"}]}
    assert feature_pairs(manifest, classifier) == [("nn-seed", "nn-ext")]  # the same training method
    assert feature_pairs({"trackers": manifest["trackers"][1:]}, classifier) == [("nn-gd", "nn-ext")]
    assert feature_pairs({"trackers": manifest["trackers"][:2]}, classifier) == []
    life = {"label": "nn-life", "kind": "nn", "model": "ext", "params": {"feature_set": "imm-innovation-9",
                                                                        "coast_gate": 9.21}}
    # another life cycle is not the seed trackers' own: only a seed tracker with the same settings is its pair
    assert feature_pairs({"trackers": [*manifest["trackers"], life]}, classifier) == [("nn-seed", "nn-ext")]
    seed_life = {**life, "label": "nn-seed-life", "model": "lm", "params": {"coast_gate": 9.21}}
    assert feature_pairs({"trackers": [*manifest["trackers"], life, seed_life]}, classifier) == [
        ("nn-seed", "nn-ext"), ("nn-seed-life", "nn-life")]

    def stat(mean, lo, hi):
        return {"mean": mean, "ci_low": lo, "ci_high": hi, "n": 10}
    metrics = {"nn-seed": {"losses": stat(30, 20, 40), "hit_rate": stat(90, 88, 92), "gospa": stat(300, 250, 350)},
               "nn-ext": {"losses": stat(5, 2, 8), "hit_rate": stat(91, 89, 93), "gospa": stat(300, 250, 350)}}
    summary = {"confidence": 0.95, "scenarios": [{"name": "S1", "trackers": {
        t: {"metrics": m} for t, m in metrics.items()}}]}
    time = "mean_time_per_scan_s"
    timing = {"scenarios": [{"name": "S1", "trackers": {"nn-seed": {time: stat(1e-3, 0.9e-3, 1.1e-3)},
                                                         "nn-ext": {time: stat(2e-3, 1.9e-3, 2.1e-3)}}}]}
    table, counts = comparison("nn-seed", "nn-ext", summary, timing)
    verdicts = {row[1]: row[4] for row in table.rows}
    assert verdicts["Association losses"] == "nn-ext better, intervals apart"
    assert verdicts["Hit rate (%)"] == "nn-ext ahead, intervals overlap"
    assert verdicts["GOSPA, mean over scans (m)"] == "equal" and verdicts["False tracks"] == "—"
    assert verdicts["Time per scan, mean over scans (ms)"] == "nn-seed better, intervals apart"
    assert counts == {1: 1, 0: 5, -1: 1}


@pytest.mark.parametrize("name", ["timing.parquet", "summary.json", "trajectories.parquet", "classifier.json"])
def test_a_file_changed_since_the_study_wrote_it_is_named(study_dir, tmp_path, name):
    import shutil

    from nnda.errors import DatasetError

    copy = tmp_path / "out"
    shutil.copytree(study_dir, copy)
    data = bytearray((copy / name).read_bytes())
    data[len(data) // 2] ^= 0x01
    (copy / name).write_bytes(bytes(data))
    with pytest.raises(DatasetError, match=rf"{name}: corrupt or edited \(its SHA-256 differs from checksums.json\)"):
        build_report(copy)


def test_a_study_directory_of_the_previous_format_is_named(study_dir, tmp_path):
    import shutil

    from nnda.errors import DatasetError

    copy = tmp_path / "out"
    shutil.copytree(study_dir, copy)
    manifest = json.loads((copy / "study.json").read_text())
    (copy / "study.json").write_text(json.dumps({**manifest, "format_version": 1}))
    with pytest.raises(DatasetError, match=r"study.json: field 'format_version' is 1; this nnda .* reads version 2"):
        build_report(copy)
