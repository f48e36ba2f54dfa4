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
