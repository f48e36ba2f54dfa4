"""The trained scorer and its model file; plain numpy, no torch.

A model file is one small JSON document::

    {"format": "nnda.model", "format_version": 2, "sha256": "<64 hex digits>",
     "feature_set": "kinematic-3", "feature_version": 1, "feature_names": [F names],
     "network": {"n_inputs": F, "n_hidden": 5, "activation": "tanh", "weights": [K floats]},
     "normaliser": {"kind": "zscore", "mean": [F floats], "scale": [F floats]},
     "metadata": {...training provenance...}}

``feature_set`` names one of `nnda.models.feature_sets.FEATURE_SETS` (F
features). ``weights`` is the flat layout of `nnda.models.mlp`. Floats are written
with full precision, so a model survives a round trip bit for bit. The file
is written atomically (`nnda.files.write_json`).

``sha256`` (format version 2) is the SHA-256 of the document's canonical
JSON without that field (`nnda.files.content_digest`): `load_model` refuses
a file whose content no longer matches it ("corrupt model file": a flipped
byte, a hand-edited weight). Files of format version 1, written before the
field existed, still load, unverified.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np

from nnda.errors import ModelError
from nnda.files import content_digest, read_json, with_content_digest, write_json
from nnda.filters.imm_kernels import kernel_array
from nnda.models.feature_sets import FEATURE_SETS
from nnda.models.features import KINEMATIC, FeatureSet
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.version import __version__

MODEL_FORMAT = "nnda.model"
MODEL_FORMAT_VERSION = 2
#: model format versions `load_model` reads (1: no ``sha256``, loaded unverified)
READABLE_MODEL_VERSIONS = (1, 2)
#: the field of a model file holding the SHA-256 of the rest of it
DIGEST_FIELD = "sha256"
MODEL_FILE = "model.json"


@dataclass(frozen=True)
class Scorer:
    """Maps raw pair features (N, F) of ``features`` to scores in (-1, 1); > 0 means "this track's contact"."""

    weights: MLPWeights
    normaliser: Normaliser
    features: FeatureSet = KINEMATIC
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.weights.n_inputs != self.features.size:
            raise ModelError(f"scorer: a {self.weights.n_inputs}-input network cannot read the "
                             f"{self.features.size} features of {self.features.name!r}")
        # `_scores`' arrays, C-contiguous once here (w1 and b1 of `MLPWeights.from_vector` are strided views)
        w, norm = self.weights, self.normaliser
        object.__setattr__(self, "_kernel_weights", tuple(
            kernel_array(a) for a in (norm.mean, norm.scale, w.w1, w.b1, w.w2)))

    def __call__(self, features: np.ndarray) -> np.ndarray:
        """Scores (N,) of raw features (N, F) as made by the feature set's functions: the normaliser, then the
        network (`_scores`: `Normaliser.transform` and `MLPWeights.__call__` in one compiled pass)."""
        x = kernel_array(features)  # a column selection may be F-ordered: copied to C order here
        if x.ndim != 2 or x.shape[1] != self.weights.n_inputs:
            raise ModelError(f"scorer: features must have shape (N, {self.weights.n_inputs}), got {x.shape}")
        score, bad = _scores(x, *self._kernel_weights, float(self.weights.b2))
        if bad >= 0:
            raise ModelError(f"scorer: features row {bad} has a non-finite value {x[bad].tolist()}")
        return score


@numba.njit(cache=True, nogil=True)
def _scores(x, mean, scale, w1, b1, w2, b2):
    """The network's outputs (N,) for raw features x (N, F): each row normalised by ``mean`` and ``scale``
    (F,), then tanh(w2 . tanh(w1 z + b1) + b2) (w1 (H, F), b1 (H,), w2 (H,)); and the first row holding a
    non-finite value (-1: none). The arithmetic of `Normaliser.transform` and `MLPWeights.__call__`, summed
    in order rather than by BLAS (agreeing to rounding): the tracker scores tens of pairs a scan, where
    numpy's eight calls cost more than the sums."""
    n, f = x.shape
    out = np.empty(n)
    z = np.empty(f)
    for p in range(n):
        for k in range(f):
            if not math.isfinite(x[p, k]):
                return out, p
            z[k] = (x[p, k] - mean[k]) / scale[k]
        total = 0.0
        for j in range(w1.shape[0]):
            a = 0.0
            for k in range(f):
                a += w1[j, k] * z[k]
            total += math.tanh(a + b1[j]) * w2[j]
        out[p] = math.tanh(total + b2)
    return out, -1


#: scores are clipped this far inside (-1, 1) before `score_log_odds`: a saturated tanh (|s| = 1 in floating
#: point) then reads as log-odds of about +-28.3, not +-inf
SCORE_CLIP = 1e-12


@numba.vectorize(["float64(float64)"], cache=True)
def score_log_odds(score):
    """Log-odds log(p / (1 - p)) that a pair is "this track's contact", read from scores s in [-1, 1].

    The network is fitted to targets +1 / -1 by least squares, whose minimiser is the conditional
    mean 2p - 1, so p = (1 + s) / 2 estimates the probability of "target" (as calibrated as the fit,
    and at the class balance of the training pairs) and log(p / (1 - p)) = log((1 + s) / (1 - s)) =
    2 artanh(s): twice the output unit's input. Score 0 is log-odds 0, p = 1/2.

    A numpy ufunc compiled by numba (scalars and arrays of any shape), callable from compiled code
    too: the neural tracker reads it a few times a scan, where np.clip's own overhead cost more than
    the arithmetic.
    """
    return 2.0 * math.atanh(min(max(score, SCORE_CLIP - 1.0), 1.0 - SCORE_CLIP))


def model_document(scorer: Scorer) -> dict:
    """The JSON content of a model file, its ``sha256`` included."""
    w = scorer.weights
    return with_content_digest({
        "format": MODEL_FORMAT,
        "format_version": MODEL_FORMAT_VERSION,
        "nnda_version": __version__,
        "feature_set": scorer.features.name,
        "feature_version": scorer.features.version,
        "feature_names": list(scorer.features.names),
        "network": {"n_inputs": w.n_inputs, "n_hidden": w.n_hidden, "activation": "tanh",
                    "weights": w.to_vector().tolist()},
        "normaliser": {"kind": "zscore", "mean": scorer.normaliser.mean.tolist(),
                       "scale": scorer.normaliser.scale.tolist()},
        "metadata": scorer.metadata,
    }, DIGEST_FIELD)


def save_model(scorer: Scorer, path: str | Path) -> Path:
    """Write ``scorer`` to the model file ``path`` atomically; returns the path."""
    return write_json(path, model_document(scorer))


def _field(doc: dict, key: str, where: Path):
    if key not in doc:
        raise ModelError(f"{where}: field {key!r} is missing")
    return doc[key]


def _floats(value, n: int, name: str, where: Path) -> np.ndarray:
    ok = isinstance(value, list) and len(value) == n and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not ok:
        raise ModelError(f"{where}: field {name!r} must be a list of {n} finite numbers")
    return np.array(value, dtype=float)


def load_model(path: str | Path) -> Scorer:
    """Read a model file, or the ``model.json`` inside a model directory, into a Scorer.

    Refuses (ModelError, naming the file and field) a missing or unreadable
    file, another format or format version, a file whose content does not
    match its ``sha256`` (format 2: "corrupt model file"), and a model built
    on another feature set or feature version than this nnda computes.
    """
    path = Path(path)
    if path.is_dir():
        path = path / MODEL_FILE
    if not path.is_file():
        raise ModelError(f"{path}: no such model file")
    doc = read_json(path, MODEL_FORMAT, READABLE_MODEL_VERSIONS, ModelError)
    feature_set, feature_version = _field(doc, "feature_set", path), _field(doc, "feature_version", path)
    features = FEATURE_SETS.get(feature_set) if isinstance(feature_set, str) else None
    if features is None or feature_version != features.version:
        known = ", ".join(f"{fs.name!r} version {fs.version}" for fs in FEATURE_SETS.values())
        raise ModelError(
            f"{path}: the model was trained on features {feature_set!r} version {feature_version!r}, "
            f"but this nnda computes {known}; retrain it with `nnda train`"
        )
    # after the feature set: a model of another set or version is refused with the same advice either way
    if doc["format_version"] >= 2:
        recorded = doc.get(DIGEST_FIELD)
        if recorded != content_digest(doc, DIGEST_FIELD):
            raise ModelError(f"{path}: corrupt model file: its content does not match field {DIGEST_FIELD!r} "
                             f"(recorded {str(recorded)[:16]}...); it was changed after `nnda train` wrote it: "
                             f"retrain it or restore a good copy")
    net, norm = _field(doc, "network", path), _field(doc, "normaliser", path)
    if not isinstance(net, dict) or not isinstance(norm, dict):
        raise ModelError(f"{path}: fields 'network' and 'normaliser' must be objects")
    n_inputs, n_hidden = _field(net, "n_inputs", path), _field(net, "n_hidden", path)
    if n_inputs != features.size or not isinstance(n_hidden, int) or n_hidden < 1:
        raise ModelError(f"{path}: field 'network' describes a {n_inputs}-{n_hidden}-1 network; "
                         f"expected {features.size} inputs ({feature_set}) and at least 1 hidden unit")
    if net.get("activation") != "tanh" or norm.get("kind") != "zscore":
        raise ModelError(f"{path}: only tanh networks with a zscore normaliser are supported, got "
                         f"activation {net.get('activation')!r}, normaliser {norm.get('kind')!r}")
    theta = _floats(_field(net, "weights", path), n_weights(n_inputs, n_hidden), "network.weights", path)
    mean = _floats(_field(norm, "mean", path), n_inputs, "normaliser.mean", path)
    scale = _floats(_field(norm, "scale", path), n_inputs, "normaliser.scale", path)
    if np.any(scale <= 0):
        raise ModelError(f"{path}: field 'normaliser.scale' must be positive")
    metadata = doc.get("metadata", {})
    if not isinstance(metadata, dict):
        raise ModelError(f"{path}: field 'metadata' must be an object")
    return Scorer(MLPWeights.from_vector(theta, n_inputs, n_hidden), Normaliser(mean, scale), features, metadata)
