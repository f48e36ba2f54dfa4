from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nnda.errors import ConfigError, ModelError
from nnda.models.experiment import fit, repeat, sweep
from nnda.models.scorer import load_model, save_model
from nnda.models.trainers import GDSettings
from nnda.reports.classifier_tables import repeats_table, sweep_table


def test_fit_is_deterministic_for_a_seed(train_pairs, tmp_path):
    a, b = fit(train_pairs, "lm", 5, seed=3), fit(train_pairs, "lm", 5, seed=3)
    assert np.array_equal(a.training.theta, b.training.theta)
    save_model(a.scorer, tmp_path / "a.json")
    save_model(b.scorer, tmp_path / "b.json")
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()
    c = fit(train_pairs, "lm", 5, seed=4)
    assert not np.array_equal(a.split.test, c.split.test)


def test_fit_normalises_on_the_training_split_and_scores_like_the_loaded_model(train_pairs, tmp_path):
    result = fit(train_pairs, "lm", 4, seed=1)
    train_features = train_pairs.features[result.split.train]
    np.testing.assert_allclose(result.scorer.normaliser.mean, train_features.mean(axis=0))
    assert not np.allclose(result.scorer.normaliser.mean, train_pairs.features.mean(axis=0), rtol=1e-6)
    loaded = load_model(save_model(result.scorer, tmp_path / "model.json"))
    np.testing.assert_allclose(loaded(train_pairs.features), result.scores, atol=1e-6)
    n = len(train_pairs)
    assert loaded.metadata["split"] == {"train": round(0.6 * n), "validation": round(0.2 * n),
                                        "test": n - round(0.6 * n) - round(0.2 * n)}
    assert result.metrics["test"].n == result.split.test.size
    assert result.metrics["all"].n == len(train_pairs)


def test_lm_learns_the_association_far_better_than_chance(train_pairs):
    result = fit(train_pairs, "lm", 5, seed=0)
    clutter_share = 1 - train_pairs.n_positive / len(train_pairs)
    assert result.metrics["test"].accuracy > clutter_share + 0.1
    assert result.metrics["test"].auc > 0.9
    assert result.training.stop_reason == "validation" and result.training.epochs < 200


def test_sweep_and_repeat_tables(train_pairs):
    s = sweep(train_pairs, [1, 2], restarts=2, method="lm", seed=0)
    assert s.test_mse.shape == (2, 2) and s.best_size in (1, 2)
    assert [r.seed for r in s.runs] == [0, 1, 0, 1]
    assert len(sweep_table(s).rows) == 2
    runs = repeat(train_pairs, ["lm"], 2, seeds=[0, 1])
    assert [(r.method, r.seed) for r in runs] == [("lm", 0), ("lm", 1)]
    assert runs[0].metrics == s.runs[2].metrics  # same seed and size: same fit
    table = repeats_table(runs)
    assert table.header == ("Measure", "LM, test", "LM, all", "thesis LM")


def test_bad_requests_are_refused(train_pairs):
    with pytest.raises(ConfigError, match="method"):
        fit(train_pairs, "adam")
    with pytest.raises(ConfigError, match="LMSettings"):
        fit(train_pairs, "lm", settings=GDSettings())
    one_class = train_pairs.subset(train_pairs.labels < 0)
    with pytest.raises(ModelError, match="one class"):
        fit(one_class)
    empty = train_pairs.subset(np.zeros(len(train_pairs), bool))
    with pytest.raises(ModelError, match="no training pairs"):
        fit(empty)
    nan = replace(train_pairs, features=train_pairs.features.copy())
    nan.features[10, 0] = np.nan
    with pytest.raises(ModelError, match="row 10"):
        fit(nan)
