"""The report's neural association ablation section from hand-made study records."""

from __future__ import annotations

from nnda.reports import association_section
from nnda.reports.features_section import COMPARED
from nnda.study.measures import TIME


def _stat(mean: float) -> dict:
    return {"mean": mean, "ci_low": mean - 1.0, "ci_high": mean + 1.0, "n": 10}


def _records(second_recipe: dict | None, association: str = "greedy", life: dict | None = None):
    manifest = {"trackers": [
        {"label": "mht", "kind": "mht", "model": None, "params": {}},
        {"label": "nn-a", "kind": "nn", "model": "a", "params": {}},
        {"label": "nn-b", "kind": "nn", "model": "b", "params": {"association": association, **(life or {})}},
    ]}
    metrics = {"accuracy": 0.95, "sensitivity": 0.9, "specificity": 0.97}
    classifier = {"models": [
        {"label": "a", "features": "imm-innovation-9", "recipe": None, "test_metrics": metrics,
         "evaluation": {"metrics": metrics}},
        {"label": "b", "features": "imm-innovation-9", "recipe": second_recipe, "test_metrics": metrics,
         "evaluation": {"metrics": {**metrics, "accuracy": 0.99}}},
    ]}
    measures = {m.key: _stat(10.0 * i) for i, m in enumerate(COMPARED) if m.key != TIME.key}
    summary = {"confidence": 0.95, "scenarios": [
        {"name": "S1", "trackers": {label: {"metrics": measures} for label in ("mht", "nn-a", "nn-b")}}]}
    timing = {"scenarios": [{"name": "S1", "trackers": {label: {TIME.key: _stat(0.001)}
                                                        for label in ("mht", "nn-a", "nn-b")}}]}
    return manifest, classifier, summary, timing


def test_absent_without_a_change_of_issue_20():
    assert association_section.tables(*_records(None)) == []
    assert association_section.tables(*_records({"encounters": 0, "dagger": 0})) == []


def test_switches_classifier_figures_and_tracking_side_by_side():
    for records in (_records({"encounters": 60, "dagger": 1}), _records(None, association="global")):
        first, tracking = association_section.tables(*records)
        assert [r[0] for r in first.rows] == ["nn-a", "nn-b"]
        assert [r[0] for r in tracking.rows] == ["mht", "nn-a", "nn-b"]  # the reference first
        assert len(tracking.header) == 1 + len(COMPARED)
    first, _ = association_section.tables(*_records({"encounters": 60, "dagger": 1}))
    row = dict(zip(first.header, first.rows[1]))
    assert (row["Encounter scenes"], row["DAgger rounds"], row["Association"], row["Threshold"]) == (
        "60", "1", "greedy", "0")
    assert row["Presets accuracy (%)"] == "99.00" and row["Own test accuracy (%)"] == "95.00"


def test_a_life_cycle_change_is_a_switch_of_its_own():
    life = {"coast_gate": 9.21, "coast_after": 0, "lifecycle": {"confirmation": "score"}}
    first, _ = association_section.tables(*_records(None, life=life))
    assert [dict(zip(first.header, r))["Life cycle"] for r in first.rows] == ["mn", "score, gate 9.21 after 0"]
    life3 = {**life, "confirmed_first": True, "gate_after_miss": False, "retrodiction": True}
    first, _ = association_section.tables(*_records(None, life=life3))
    want = "score, gate 9.21 after 0, confirmed first, retrodiction"
    assert dict(zip(first.header, first.rows[1]))["Life cycle"] == want
    first, _ = association_section.tables(*_records(None, life={**life3, "release_on_deletion": True}))
    assert dict(zip(first.header, first.rows[1]))["Life cycle"] == f"{want}, release on deletion"
    first, _ = association_section.tables(*_records(None, life={"release_on_deletion": True}))
    assert [dict(zip(first.header, r))["Life cycle"] for r in first.rows] == ["mn", "mn, release on deletion"]
    first, _ = association_section.tables(*_records(None, life={"lifecycle": {"confirmation": "score"}}))
    assert dict(zip(first.header, first.rows[1]))["Life cycle"] == "score"
