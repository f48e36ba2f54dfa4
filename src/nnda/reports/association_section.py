"""The report's "Neural association ablation" section: what each extension of the method buys.

Present when a neural tracker of the study uses an extension of Vargas
Avila (2015)'s method: a model on the context features (``imm-context-14``), one trained with
multi-target encounter scenes or DAgger rounds (its metadata ``recipe``),
the global association, or a life cycle other than M/N alone (the score
rule, ``coast_gate``). Two tables, side by side:

* per neural tracker, its switches (features, encounter scenes, DAgger
  rounds and the share of tracks on clutter kept, association, threshold,
  life cycle) and its model's classifier figures: on its own test split
  (what training saw) and on the oracle pairs of the 17 training presets,
  one common set for every model (``classifier.json``);
* per scenario, every tracker (MHT and GNN as references) on the measures
  association changes (`nnda.reports.features_section.COMPARED`), each
  ``mean [low, high]`` over runs, so the classifier's gains can be read
  against the tracker's.

Reads ``study.json``, ``classifier.json``, ``summary.json`` and ``timing.json``.
"""

from __future__ import annotations

from nnda.models.context import IMM_CONTEXT
from nnda.reports.features_section import COMPARED
from nnda.reports.study_summary import stat
from nnda.reports.text_table import DASH, TextTable, stat_cell

#: the classifier figures shown per model (keys of `nnda.models.metrics.ClassifierMetrics.as_dict`)
FIGURES = ("accuracy", "sensitivity", "specificity")


def _switches(tracker: dict, model: dict) -> dict:
    recipe = model.get("recipe") or {}
    params = tracker["params"]
    return {"features": model.get("features", DASH), "encounters": recipe.get("encounters", 0),
            "dagger": recipe.get("dagger", 0), "ratio": recipe.get("dagger_ratio"),
            "association": params.get("association", "greedy"), "threshold": params.get("threshold", 0.0),
            "life": _life_cycle(params)}


#: the neural tracker's switches of its coasting tracks (`nnda.tracking.neural.NeuralConfig`), as the column names them
_COASTING = {"confirmed_first": "confirmed first", "gate_after_miss": "gate after miss", "retrodiction": "retrodiction"}


def _life_cycle(params: dict) -> str:
    """The tracker's confirmation rule, its coasting fallback and the switches on, then the release of a deleted
    track's contact: "mn", "score, gate 9.21 after 0, confirmed first, retrodiction, release on deletion"."""
    parts = [(params.get("lifecycle") or {}).get("confirmation", "mn")]
    gate = params.get("coast_gate")
    if gate is not None:
        parts += [f"gate {gate:g} after {params.get('coast_after', 1)}",
                  *(name for key, name in _COASTING.items() if params.get(key))]
    if params.get("release_on_deletion"):
        parts.append("release on deletion")
    return ", ".join(parts)


def neural_trackers(manifest: dict, classifier: dict) -> list[tuple[dict, dict]]:
    """(tracker, model entry) of every neural tracker, if one of them uses an extension (module docstring); else []."""
    models = {m["label"]: m for m in classifier["models"]}
    nn = [(t, models[t["model"]]) for t in manifest["trackers"] if t["kind"] == "nn" and t.get("model") in models]
    changed = any(s["features"] == IMM_CONTEXT.name or s["encounters"] or s["dagger"] or s["association"] != "greedy"
                  or s["life"] != "mn" for s in (_switches(t, m) for t, m in nn))
    return nn if changed else []


def _figure(metrics: dict | None, key: str) -> str:
    value = (metrics or {}).get(key)
    return DASH if value is None else f"{100 * value:.2f}"


def classifier_table(nn: list[tuple[dict, dict]]) -> TextTable:
    """The switches and classifier figures of each neural tracker's model."""
    rows = []
    for tracker, model in nn:
        s = _switches(tracker, model)
        common = (model.get("evaluation") or {}).get("metrics")
        rows.append((tracker["label"], s["features"], str(s["encounters"]), str(s["dagger"]),
                     DASH if s["ratio"] is None else f"{s['ratio']:g}", s["association"], f"{s['threshold']:g}",
                     s["life"],
                     *(_figure(model.get("test_metrics"), k) for k in FIGURES),
                     *(_figure(common, k) for k in FIGURES)))
    header = ("Tracker", "Features", "Encounter scenes", "DAgger rounds", "DAgger ratio", "Association", "Threshold",
              "Life cycle", *(f"Own test {k} (%)" for k in FIGURES), *(f"Presets {k} (%)" for k in FIGURES))
    note = ("Own test: the model's test split (20 % of its own training pairs, harvested ones included). Presets: "
            "every oracle pair of the 17 training presets, the same set for every model. Life cycle: the confirmation "
            "rule (mn: M/N; score: the track score), and with coast_gate the IMM gate in which a confirmed track "
            "left without a pick after that many misses takes its nearest free contact, then the switches on "
            "(confirmed tracks first, the gate on a pick after a miss, the one-scan retrodiction); release on "
            "deletion: a track deleted in the scan it took a contact gives the contact back.")
    return TextTable("Neural trackers: what each model was trained on and how it classifies", header,
                     tuple(rows), note)


def tracking_table(scenario: dict, timing: dict, labels: list[str], confidence: float) -> TextTable:
    """One scenario: a row per tracker, a column per compared measure, ``mean [low, high]``."""
    rows = tuple((label, *(stat_cell(stat(scenario, timing, label, m.key), m.fmt, m.scale) for m in COMPARED))
                 for label in labels if label in scenario["trackers"])
    header = ("Tracker", *(m.title for m in COMPARED))
    return TextTable(f"{scenario['name']}: tracking", header, rows,
                     f"Mean [{confidence:.0%} t-interval] over runs.")


def tables(manifest: dict, classifier: dict, summary: dict, timing: dict) -> list[TextTable]:
    """The section's tables (empty when no neural tracker uses an extension)."""
    nn = neural_trackers(manifest, classifier)
    if not nn:
        return []
    neural = {t["label"] for t, _ in nn}
    labels = [t["label"] for t in manifest["trackers"] if t["kind"] in ("mht", "gnn") and t["label"] not in neural]
    labels += [t["label"] for t, _ in nn]
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    return [classifier_table(nn)] + [tracking_table(sc, timing_by[sc["name"]], labels, summary["confidence"])
                                     for sc in summary["scenarios"]]
