"""A finished tiny study with a model file, shared by the report tests."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, save_model
from nnda.reports.study_report import write_report
from nnda.study.compare import compare
from nnda.study.config import load_study

#: datasets the hand-made model claims to be trained on (two short training presets)
TRAINED_ON = ["train08/run-0/seed-8", "train09/run-0/seed-9"]
PAIR_OPTIONS = {"history": "measured", "other_targets": "negative", "max_missed": 3}

SCENARIO = """
name = "pair"
duration_s = 40
seed = 2
[clutter]
count = 15
[[targets]]
name = "a"
x_m = -10000
y_m = 10000
heading_deg = 90
speed_m_s = 100
segments = [{duration_s = 40}]
[[targets]]
name = "b"
x_m = 12000
y_m = -8000
heading_deg = 200
speed_m_s = 120
segments = [{duration_s = 20}, {duration_s = 20, normal_accel = 5.0}]
"""

STUDY = """
name = "tiny"
seed = 4
runs = 2

[models]
lm = "model"

[trackers.gnn-tight]
kind = "gnn"
params = { gate = 6.0 }

[trackers.gnn]
kind = "gnn"

[[scenarios]]
config = "pair.toml"
[[scenarios]]
preset = "S4"
"""


def write_model(directory) -> None:
    """A 3-5-1 model with seeded random weights and the metadata `nnda train` records."""
    rng = np.random.default_rng(7)
    weights = MLPWeights.from_vector(rng.normal(0.0, 0.8, n_weights(3, 5)), 3, 5)
    metadata = {"method": "lm", "epochs": 12, "best_epoch": 6, "stop_reason": "validation", "seed": 0,
                "pair_options": PAIR_OPTIONS, "dataset_names": TRAINED_ON,
                "test_metrics": {"tp": 10, "fn": 2, "tn": 30, "fp": 3, "sensitivity": 10 / 12,
                                 "specificity": 30 / 33, "fpr": 3 / 33, "accuracy": 40 / 45, "auc": 0.9, "mse": 0.3}}
    save_model(Scorer(weights, Normaliser(np.array([0.0, 0.0, 2.5]), np.array([40.0, 8.0, 1.0])), metadata=metadata),
               directory / "model.json")


@pytest.fixture(scope="session")
def pair_scenario() -> str:
    """The tiny study's two-target scenario config (TOML text), for other studies of the report tests."""
    return SCENARIO


@pytest.fixture(scope="session")
def study_dir(tmp_path_factory):
    """The study directory of a finished tiny study, report included."""
    root = tmp_path_factory.mktemp("tiny-study")
    (root / "pair.toml").write_text(SCENARIO)
    (root / "study.toml").write_text(STUDY)
    write_model(root / "model")
    compare(load_study(root / "study.toml"), root / "out", workers=1)
    write_report(root / "out")
    return root / "out"
