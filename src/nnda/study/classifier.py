"""The classifier side of a study: what each model file says about itself, and its ROC.

A model file (`nnda.models.scorer`) carries its training provenance in its
metadata: method, epochs, best epoch, split sizes, test-split metrics, the
pair options and the names of the datasets its pairs came from
(``<scenario>/run-<run>/seed-<seed>``, `nnda.models.pairs.dataset_name`).
A feature ablation (``nnda train --ablation``) named by the study is read
and checked here (`read_ablation`) and kept in the study directory for the
report.

The ROC and the metrics over *all* pairs (the "Total" rows of Vargas Avila (2015), Tables 6.1-6.3)
need the scores of every pair, which the file does not hold, so they are
computed here: the named datasets are regenerated from their presets with
their seed and run (bit-identical to the training data), their pairs built
with the recorded options on the model's own feature set, and scored. When
the names are not presets (a model trained on other data), the 17 training
presets with their own seeds stand in, and the record says so.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nnda.data.generator import generate
from nnda.data.presets import GROUPS, PRESETS
from nnda.errors import DatasetError
from nnda.files import finite_or_none, read_json
from nnda.models.ablation import ABLATION_FILE, ABLATION_FORMAT, ABLATION_FORMAT_VERSION
from nnda.models.metrics import classifier_metrics, roc
from nnda.models.pairs import PairSet, model_pair_options, pairs_from_datasets
from nnda.models.scorer import load_model

if TYPE_CHECKING:
    from nnda.study.kinds.track import ModelPlan

CLASSIFIER_FORMAT = "nnda.study-classifier"
FORMAT_VERSION = 1
CLASSIFIER_FILE = "classifier.json"
_NAME = re.compile(r"^(?P<scenario>[^/]+)/run-(?P<run>\d+)/seed-(?P<seed>\d+)$")


def training_sources(metadata: dict) -> tuple[list[tuple[str, int, int]], str]:
    """(preset, run, seed) of each dataset a model was trained on, and a description of the choice."""
    names = metadata.get("dataset_names")
    found = []
    if isinstance(names, list):
        for name in names:
            m = _NAME.match(name) if isinstance(name, str) else None
            if m is None or m["scenario"] not in PRESETS:
                found = []
                break
            found.append((m["scenario"], int(m["run"]), int(m["seed"])))
    if found:
        return found, f"the model's own training data, regenerated ({len(found)} datasets)"
    fallback = [(name, 0, PRESETS[name].seed) for name in GROUPS["train"]]
    return fallback, "the 17 training presets with their own seeds (the model's training data are not presets)"


def _pairs(sources: list[tuple[str, int, int]], options: dict) -> PairSet:
    return pairs_from_datasets((generate(PRESETS[name], seed, run) for name, run, seed in sources), **options)


def _floats(a: np.ndarray) -> list[float]:
    return [float(v) for v in a]


def read_ablation(path: Path) -> dict:
    """The ``ablation.json`` of an ``nnda train --ablation`` directory (or the file itself), checked."""
    file = path / ABLATION_FILE if path.is_dir() else path
    if not file.is_file():
        raise DatasetError(f"{path}: no {ABLATION_FILE} here; write one with `nnda train --ablation --repeats 10`")
    doc = read_json(file, ABLATION_FORMAT, ABLATION_FORMAT_VERSION)
    rows = doc.get("results")
    if not isinstance(rows, list) or not rows or not all(
            isinstance(r, dict) and {"history", "variant", "features", "runs", "roc"} <= r.keys() for r in rows):
        raise DatasetError(f"{file}: field 'results' must be a non-empty list of ablation variants")
    return doc


def evaluate_models(models: tuple[ModelPlan, ...] | list[ModelPlan]) -> dict:
    """The ``classifier.json`` content for the study's models (deterministic)."""
    cache: dict[tuple, PairSet] = {}
    entries = []
    for m in models:
        scorer = load_model(m.path)
        meta = scorer.metadata
        # the cache key holds the feature set, so a seed and an extended model never share pairs
        options = model_pair_options(meta, scorer.features.name)
        sources, described = training_sources(meta)
        key = (tuple(sources), tuple(sorted(options.items())))
        if key not in cache:
            cache[key] = _pairs(sources, options)
        pairs = cache[key]
        scores = scorer(pairs.features)
        metrics = classifier_metrics(pairs.labels, scores).as_dict()
        fpr, tpr = roc(pairs.labels, scores)
        entries.append({
            "label": m.label, "file": m.path.name, "sha256": m.sha256,
            "method": meta.get("method"), "features": scorer.features.name, "n_hidden": scorer.weights.n_hidden,
            "epochs": meta.get("epochs"), "best_epoch": meta.get("best_epoch"),
            "stop_reason": meta.get("stop_reason"), "seed": meta.get("seed"),
            "split": meta.get("split"), "test_metrics": meta.get("test_metrics"), "recipe": meta.get("recipe"),
            "evaluation": {"pairs_from": described, "pair_options": options, "n_pairs": len(pairs),
                           "n_positive": pairs.n_positive,
                           "metrics": {k: (finite_or_none(v) if isinstance(v, float) else v)
                                       for k, v in metrics.items()}},
            "roc": {"fpr": _floats(fpr), "tpr": _floats(tpr)},
        })
    return {"format": CLASSIFIER_FORMAT, "format_version": FORMAT_VERSION, "models": entries}
