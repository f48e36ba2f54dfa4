from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from nnda.errors import ModelError
from nnda.files import content_digest, with_content_digest
from nnda.models.features import KINEMATIC
from nnda.models.mlp import MLPWeights, n_weights, nguyen_widrow, unpack
from nnda.models.network import as_tensor, forward
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, load_model, save_model
from tolerances import RTOL


@pytest.fixture
def scorer() -> Scorer:
    rng = np.random.default_rng(7)
    weights = MLPWeights.from_vector(rng.normal(0, 1.5, n_weights(3, 5)), 3, 5)
    return Scorer(weights, Normaliser(np.array([90.0, 0.1, 4.0]), np.array([100.0, 28.0, 2.4])),
                  metadata={"method": "lm", "seed": 3})


def test_flat_layout_puts_each_neurons_bias_first():
    theta = np.arange(n_weights(3, 2), dtype=float)  # 2*(3+1) + 2 + 1 = 11
    w1, b1, w2, b2 = unpack(theta, 3, 2)
    assert b1.tolist() == [0.0, 4.0] and w1.tolist() == [[1, 2, 3], [5, 6, 7]]
    assert b2 == 8.0 and w2.tolist() == [9.0, 10.0]
    assert np.array_equal(MLPWeights.from_vector(theta, 3, 2).to_vector(), theta)


def test_numpy_network_equals_torch(scorer):
    x = np.random.default_rng(1).normal(0, 2, (500, 3))
    theta = scorer.weights.to_vector()
    with torch.no_grad():
        expected = forward(as_tensor(theta), as_tensor(x), 5).numpy()
    np.testing.assert_allclose(scorer.weights(x), expected, rtol=1e-9, atol=1e-9)  # outputs in (-1, 1)


def test_the_compiled_scorer_is_the_normaliser_then_the_numpy_network(scorer):
    x = np.random.default_rng(2).normal(50, 80, (300, 3))
    expected = scorer.weights(scorer.normaliser.transform(x))
    np.testing.assert_allclose(scorer(x), expected, rtol=RTOL, atol=RTOL)  # summation order only; outputs in (-1, 1)
    assert scorer(x[:0]).shape == (0,)


def test_model_file_round_trip_is_exact(scorer, tmp_path):
    path = save_model(scorer, tmp_path / "m" / "model.json")
    loaded = load_model(tmp_path / "m")  # a model directory works too
    features = np.random.default_rng(2).normal([100, 0, 4], [100, 30, 2], (200, 3))
    assert np.array_equal(loaded(features), scorer(features))
    assert loaded.metadata == scorer.metadata
    assert [p.name for p in path.parent.iterdir()] == ["model.json"]  # no temporary left behind


def _rewrite(path, **changes):
    """Change fields of a model file as a writer of those values would have: its digest re-recorded."""
    doc = json.loads(path.read_text())
    doc.update(changes)
    path.write_text(json.dumps(with_content_digest(doc, "sha256")))


def test_loader_refuses_bad_files(scorer, tmp_path):
    with pytest.raises(ModelError, match="no such model file"):
        load_model(tmp_path / "missing.json")
    path = save_model(scorer, tmp_path / "model.json")
    path.write_text("{not json")
    with pytest.raises(ModelError, match="not valid JSON"):
        load_model(path)
    save_model(scorer, path)
    _rewrite(path, format="nnda.dataset")
    with pytest.raises(ModelError, match="field 'format'"):
        load_model(path)
    save_model(scorer, path)
    _rewrite(path, feature_version=KINEMATIC.version + 1)
    with pytest.raises(ModelError, match=f"{KINEMATIC.name!r} version {KINEMATIC.version + 1}.*retrain"):
        load_model(path)
    save_model(scorer, path)
    doc = json.loads(path.read_text())
    _rewrite(path, network={**doc["network"], "weights": doc["network"]["weights"][:-1]})
    with pytest.raises(ModelError, match="network.weights"):
        load_model(path)


def test_a_hand_edited_weight_is_a_corrupt_model_file_and_format_1_loads_unverified(scorer, tmp_path):
    path = save_model(scorer, tmp_path / "model.json")
    doc = json.loads(path.read_text())
    assert doc["format_version"] == 2 and doc["sha256"] == content_digest(doc, "sha256")
    doc["network"]["weights"][4] += 1e-12
    path.write_text(json.dumps(doc, indent=1))
    with pytest.raises(ModelError, match=rf"{path}: corrupt model file: its content does not match field 'sha256'"):
        load_model(path)
    del doc["sha256"]
    path.write_text(json.dumps({**doc, "format_version": 1}))  # written before the digest existed
    assert load_model(path).weights.to_vector()[4] == scorer.weights.to_vector()[4] + 1e-12


def test_scorer_refuses_nan_and_wrong_shapes(scorer):
    with pytest.raises(ModelError, match="row 1 has a non-finite value"):
        scorer(np.array([[1.0, 2.0, 2.0], [np.nan, 0.0, 2.0]]))
    with pytest.raises(ModelError, match=r"shape \(N, 3\)"):
        scorer(np.ones((4, 2)))


def test_nguyen_widrow_spreads_units_over_the_active_region():
    rng = np.random.default_rng(0)
    w = nguyen_widrow(np.tile([-1.0, 1.0], (3, 1)), 5, rng)
    magnitude = 2 * 0.7 * 5 ** (1 / 3)  # tanh active region [-2, 2] times 0.7 H^(1/N)
    np.testing.assert_allclose(np.linalg.norm(w.w1, axis=1), magnitude)
    np.testing.assert_allclose(np.abs(w.b1), magnitude * np.abs(np.linspace(-1, 1, 5)))
    assert np.linalg.norm(w.w2) == pytest.approx(1.4) and w.b2 == 0.0
    # an input range [0, 10] maps onto [-1, 1]: same pre-activations at the range ends
    wide = nguyen_widrow(np.tile([0.0, 10.0], (3, 1)), 5, np.random.default_rng(0))
    for lo, hi in ((np.zeros(3), -np.ones(3)), (np.full(3, 10.0), np.ones(3))):
        np.testing.assert_allclose(wide.w1 @ lo + wide.b1, w.w1 @ hi + w.b1)


def test_metadata_of_any_json_shape_survives_the_digest(scorer, tmp_path):
    """Integer keys, tuples and NaN read back as strings, lists and null: the digest is of what reads back."""
    odd = Scorer(scorer.weights, scorer.normaliser, metadata={"by_size": {10: 0.5, 9: 0.25}, "pair": (1, 2),
                                                               "auc": float("nan")})
    loaded = load_model(save_model(odd, tmp_path / "model.json"))
    assert loaded.metadata == {"by_size": {"10": 0.5, "9": 0.25}, "pair": [1, 2], "auc": None}
