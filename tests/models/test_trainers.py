from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from nnda.errors import ModelError
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.trainers import GDSettings, LMSettings, Subset, train_gd, train_lm


@pytest.fixture(scope="module")
def problem():
    """A fixed regression problem a 3-3-1 network can fit: a teacher network plus noise."""
    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, 3))
    teacher = MLPWeights.from_vector(rng.normal(0, 1, n_weights(3, 3)), 3, 3)
    y = teacher(x) + rng.normal(0, 0.05, 200)
    return Subset(x, y), rng.uniform(-0.5, 0.5, n_weights(3, 3))


def test_lm_reaches_the_loss_of_minpack_lm_from_the_same_start(problem):
    train, theta0 = problem
    ours = train_lm(theta0, 3, train, settings=LMSettings(max_epochs=500))
    ref = least_squares(lambda th: MLPWeights.from_vector(th, 3, 3)(train.x) - train.y, theta0, method="lm")
    ref_mse = np.mean(ref.fun ** 2)
    assert ours.stop_reason == "min_grad"
    assert ours.loss["train"][-1] == pytest.approx(ref_mse, rel=1e-3)
    assert ours.loss["train"][-1] < 0.2 * ours.loss["train"][0]


def test_lm_lowers_the_loss_on_every_accepted_step_and_beats_gd_in_epochs(problem):
    train, theta0 = problem
    lm = train_lm(theta0, 3, train, settings=LMSettings(max_epochs=500))
    gd = train_gd(theta0, 3, train, settings=GDSettings(max_epochs=1000))
    assert np.all(np.diff(lm.loss["train"]) < 0)
    assert lm.mu.size == lm.epochs + 1 and np.all(lm.mu > 0)
    assert gd.epochs == 1000 and gd.loss["train"][-1] < gd.loss["train"][0]
    epochs_to_match_gd = int(np.argmax(lm.loss["train"] <= gd.loss["train"][-1]))
    assert 0 < epochs_to_match_gd < 50
    assert lm.loss["train"][-1] < gd.loss["train"][-1]


@pytest.mark.parametrize("trainer, settings", [(train_lm, LMSettings()), (train_gd, GDSettings(lr=0.5))])
def test_early_stopping_returns_the_best_validation_weights(problem, trainer, settings):
    train, theta0 = problem
    # a validation set with negated targets gets worse whenever training improves
    result = trainer(theta0, 3, train, Subset(train.x, -train.y), settings=settings)
    assert result.stop_reason == "validation"
    assert result.epochs == settings.max_fail and result.best_epoch == 0
    np.testing.assert_array_equal(result.theta, theta0)


def test_losses_are_logged_for_every_subset_and_epoch(problem):
    train, theta0 = problem
    seen = []
    result = train_lm(theta0, 3, train, Subset(train.x[:50], train.y[:50]), Subset(train.x[50:], train.y[50:]),
                      settings=LMSettings(max_epochs=5, max_fail=100), on_epoch=lambda e, loss: seen.append((e, loss)))
    assert sorted(result.loss) == ["test", "train", "validation"]
    assert all(v.shape == (6,) for v in result.loss.values())
    assert [e for e, _ in seen] == list(range(6))
    assert seen[-1][1]["test"] == result.loss["test"][-1]


def test_nan_inputs_are_refused(problem):
    train, theta0 = problem
    x = train.x.copy()
    x[3, 1] = np.nan
    with pytest.raises(ModelError, match="train subset.*non-finite"):
        train_lm(theta0, 3, Subset(x, train.y))
