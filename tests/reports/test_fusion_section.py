"""The report's fusion section on a tiny harbour study: its table lists every tracker with the sensors it
uses, its sentences come from summary.json's intervals, and a study without single-sensor trackers has none."""

from __future__ import annotations

import json

import pytest

from nnda.reports.study_report import build_report
from nnda.study.compare import compare
from nnda.study.config import load_study

STUDY = """name = "tiny-harbour"
seed = 2
runs = 3
gospa_cutoff_m = 500.0
[trackers.radar2]
kind = "fusion-central"
params = { use_sensors = ["radar2"] }
[trackers.fusion-aa]
kind = "fusion-aa"
[[scenarios]]
config = "harbour.toml"
"""


@pytest.fixture(scope="module")
def harbour_study(tmp_path_factory):
    from nnda.data.presets import PRESETS

    root = tmp_path_factory.mktemp("harbour-study")
    scene = PRESETS["harbour"].model_copy(update={"duration_s": 40.0}).model_dump(mode="json")
    (root / "harbour.json").write_text(json.dumps(scene))
    (root / "study.toml").write_text(STUDY.replace("harbour.toml", "harbour.json"))
    compare(load_study(root / "study.toml"), root / "out", workers=1)
    return root / "out"


def test_the_section_compares_fusion_with_the_single_radar(harbour_study):
    md, html, _ = build_report(harbour_study)
    section = md[md.index("## Fusion against single sensors"):]
    section = section[:section.index("\n## ", 5)]
    summary = json.loads((harbour_study / "summary.json").read_text())
    gospa = {label: rec["metrics"]["gospa"]["mean"] for label, rec in summary["scenarios"][0]["trackers"].items()}
    assert "| radar2 | radar2 |" in section and "| fusion-aa | all |" in section
    assert f"**radar2** (GOSPA {gospa['radar2']:.1f} m)" in section
    assert f"fusion-aa: GOSPA {gospa['fusion-aa'] / gospa['radar2']:.2f}x the best single sensor's" in section
    assert 'id="fusion"' in html or "Fusion against single sensors" in html


def test_no_section_without_single_sensor_trackers(tmp_path):
    from nnda.data.presets import PRESETS

    scene = PRESETS["harbour"].model_copy(update={"duration_s": 20.0}).model_dump(mode="json")
    (tmp_path / "harbour.json").write_text(json.dumps(scene))
    text = STUDY.replace("harbour.toml", "harbour.json").replace("runs = 3", "runs = 1")
    text = text.replace('[trackers.radar2]\nkind = "fusion-central"\nparams = { use_sensors = ["radar2"] }\n', "")
    (tmp_path / "study.toml").write_text(text)
    compare(load_study(tmp_path / "study.toml"), tmp_path / "out", workers=1)
    md, _, _ = build_report(tmp_path / "out")
    assert "## Fusion against single sensors" not in md


def _records(covered: float, missed: float, localised: float) -> dict:
    return {"metrics": {"tracked_undetected": {"mean": covered}, "gospa_missed": {"mean": missed},
                        "gospa_localisation": {"mean": localised}}}


def test_a_single_phd_filter_that_trails_the_union_is_explained_from_its_own_pd_and_threshold():
    from nnda.reports.fusion_section import single_filter_reasons

    manifest = {"study": {"trackers": {
        "central": {"kind": "fusion-central", "params": {"extraction_scans": 1}},
        "radar1": {"kind": "fusion-central", "params": {"use_sensors": ["radar1"]}},
        "merge": {"kind": "fusion-merge", "params": {}},
        "central-pd": {"kind": "fusion-central", "params": {"pd": 0.8, "extraction_threshold": 0.5}}}}}
    trackers = {"radar1": _records(40.0, 1e5, 4_000.0), "merge": _records(85.3, 18_333.0, 2_779.0),
                "central": _records(18.8, 85_781.0, 1_496.0), "central-pd": _records(90.0, 85_781.0, 1_496.0)}
    lines = single_filter_reasons(manifest, trackers)
    assert len(lines) == 1 and lines[0].startswith("- Why central (one PHD filter on every sensor's sweeps) trails "
                                                   "merge: it covers 18.8% of the undetected target-scans "
                                                   "against 85.3%, and GOSPA's missed-target part is 85,781 m² "
                                                   "against 18,333 m²")
    assert "1 - p_D = 0.10, which leaves any weight under 8.0 below the extraction threshold 0.80" in lines[0]
    trackers["central-pd"] = _records(10.0, 9e4, 1_000.0)
    assert "1 - p_D = 0.20, which leaves any weight under 2.5 below the extraction threshold 0.50" in (
        single_filter_reasons(manifest, trackers)[1])
    del manifest["study"]["trackers"]["merge"]
    assert single_filter_reasons(manifest, trackers) == []
