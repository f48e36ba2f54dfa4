"""A small study with Stone Soup peers runs end to end, and its report has the "Against Stone Soup" section."""

from __future__ import annotations

import pytest

from nnda.reports.study_report import write_report
from nnda.study.compare import compare
from nnda.study.config import study_from_dict

pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")


def test_study_with_peers_end_to_end(tmp_path, small_scenario):
    (tmp_path / "pair.json").write_text(small_scenario.model_dump_json())
    trackers = {"gnn": {"kind": "gnn"}, "jpda": {"kind": "jpda"},
                "ss-gnn": {"kind": "stonesoup-gnn"}, "ss-jpda": {"kind": "stonesoup-jpda"}}
    study = study_from_dict({"name": "peers", "runs": 2, "trackers": trackers,
                             "scenarios": [{"config": "pair.json"}]}, base=tmp_path)
    result = compare(study, tmp_path / "out", workers=1)
    write_report(tmp_path / "out")
    sc = result.summary["scenarios"][0]["trackers"]
    assert sc["ss-gnn"]["metrics"]["confirmed_tracks"]["mean"] >= 2
    md = (tmp_path / "out" / "report.md").read_text()
    assert "## Against Stone Soup" in md
    assert "x vs ss-gnn" in md and "x vs ss-jpda" in md and "How the peers are set up" in md
    assert 'id="peers"' in (tmp_path / "out" / "report.html").read_text()


def test_no_section_without_peers(tmp_path, small_scenario):
    (tmp_path / "pair.json").write_text(small_scenario.model_dump_json())
    study = study_from_dict({"runs": 1, "trackers": {"gnn": {"kind": "gnn"}},
                             "scenarios": [{"config": "pair.json"}]}, base=tmp_path)
    compare(study, tmp_path / "out", workers=1)
    write_report(tmp_path / "out")
    assert "Against Stone Soup" not in (tmp_path / "out" / "report.md").read_text()


def test_the_shipped_study_against_stone_soup_plans():
    from pathlib import Path

    from nnda.study.config import load_study
    from nnda.study.plan import plan_study

    study = load_study(Path(__file__).resolve().parents[2] / "studies" / "against-stonesoup.toml")
    plan = plan_study(study)  # every input checked, nothing run
    assert {t.kind for t in plan.kinds["track"].trackers} >= {"stonesoup-gnn", "stonesoup-jpda", "mht"}
    assert len(plan.jobs) == 6 * 3 * 5
