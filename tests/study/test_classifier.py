"""The study's classifier evaluation: every model scored on the pairs of its own feature set."""

from __future__ import annotations

import numpy as np

from nnda.models.feature_sets import feature_set
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, save_model
from nnda.study.classifier import evaluate_models
from nnda.study.kinds.track import ModelPlan


def model_plan(directory, label: str, features: str) -> ModelPlan:
    """A model of random weights on ``features``, trained (says its metadata) on train08, as `fit` writes
    it: without a feature set among its pair options, like every model the Python API saves."""
    fs = feature_set(features)
    rng = np.random.default_rng(3)
    weights = MLPWeights.from_vector(rng.normal(0.0, 0.5, n_weights(fs.size, 4)), fs.size, 4)
    metadata = {"method": "lm", "pair_options": {"history": "measured"}, "dataset_names": ["train08/run-0/seed-8"]}
    scorer = Scorer(weights, Normaliser(np.zeros(fs.size), np.full(fs.size, 10.0)), fs, metadata=metadata)
    return ModelPlan(label, save_model(scorer, directory / label / "model.json"), "-", metadata)


def test_a_seed_model_and_an_extended_model_are_each_scored_on_their_own_pairs(tmp_path):
    seed = model_plan(tmp_path, "seed", "kinematic-3")
    ext = model_plan(tmp_path, "ext", "imm-innovation-9")
    together = evaluate_models([seed, ext])["models"]
    assert [m["features"] for m in together] == ["kinematic-3", "imm-innovation-9"]
    assert [m["evaluation"]["pair_options"]["features"] for m in together] == ["kinematic-3", "imm-innovation-9"]
    # the same entry as when the model is evaluated alone, in either order
    assert together[1] == evaluate_models([ext])["models"][0]
    assert evaluate_models([ext, seed])["models"][1] == together[0]
