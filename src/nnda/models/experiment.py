"""Training protocols: one model, the hidden-size sweep and seeded repeats (after Vargas Avila (2015)).

One *fit* with seed s: split the pairs 60/20/20 and draw the initial
weights from two independent streams of ``SeedSequence(s)``, fit the
z-score normaliser on the training split, train, and measure every subset.
Initial weights: Nguyen-Widrow by default (MATLAB's), or every weight
uniform in [-0.5, 0.5] (``init="uniform"``). The
same seed gives the same split and start for GD and LM, so the two methods
are compared on identical problems. With ``starts`` > 1 the network is trained
from that many successive draws of the initial-weight
stream (the first is the one-start draw) and the run with the lowest
validation MSE at its returned epoch is kept: LM stalls in a saturated
minimum from about one start in 20, and the validation split, not the
test split, picks the survivor.

Sweep: for each hidden size, ``restarts`` fits with seeds
s, s+1, ...; the size with the lowest mean test MSE wins. Restart r uses
the same split and the same random stream for every size.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Literal

import numpy as np

from nnda.errors import ConfigError, ModelError
from nnda.models.metrics import ClassifierMetrics, classifier_metrics
from nnda.models.mlp import MLPWeights, n_weights, nguyen_widrow
from nnda.models.pairs import PairSet
from nnda.models.preprocessing import Normaliser, Split, split_indices
from nnda.models.scorer import Scorer
from nnda.models.trainers import (
    EpochCallback,
    GDSettings,
    LMSettings,
    Subset,
    TrainingResult,
    train_gd,
    train_lm,
)
from nnda.version import __version__

Method = Literal["gd", "lm"]
METHODS: tuple[Method, ...] = ("gd", "lm")
Init = Literal["nguyen-widrow", "uniform"]


@dataclass(frozen=True)
class FitResult:
    """A trained scorer with its history, its split and its metrics per subset.

    ``scores`` (N,) are the scorer's outputs for every pair of the set;
    ``metrics`` maps train, validation, test and all to ClassifierMetrics.
    """

    method: Method
    seed: int
    scorer: Scorer
    training: TrainingResult
    split: Split
    scores: np.ndarray
    metrics: dict[str, ClassifierMetrics]


def _streams(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    split, init = np.random.SeedSequence(seed).spawn(2)
    return np.random.default_rng(split), np.random.default_rng(init)


def _settings(method: Method, settings: GDSettings | LMSettings | None) -> GDSettings | LMSettings:
    if method not in METHODS:
        raise ConfigError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    expected = GDSettings if method == "gd" else LMSettings
    if settings is None:
        return expected()
    if not isinstance(settings, expected):
        raise ConfigError(f"method {method!r} takes {expected.__name__}, got {type(settings).__name__}")
    return settings


def _check_pairs(pairs: PairSet) -> None:
    if len(pairs) == 0:
        raise ModelError("no training pairs: the data gave none")
    if pairs.n_positive == 0 or pairs.n_positive == len(pairs):
        raise ModelError(f"the {len(pairs)} training pairs hold one class only "
                         f"({pairs.n_positive} own-contact pairs); both are needed")
    if not np.isfinite(pairs.features).all():
        bad = int(np.flatnonzero(~np.isfinite(pairs.features).all(axis=1))[0])
        raise ModelError(f"training pairs: features row {bad} has a non-finite value")


def initial_weights(init: Init, x_train: np.ndarray, n_hidden: int, rng: np.random.Generator) -> MLPWeights:
    """Starting weights for normalised training inputs ``x_train`` (P, N)."""
    if init == "nguyen-widrow":
        return nguyen_widrow(np.column_stack([x_train.min(axis=0), x_train.max(axis=0)]), n_hidden, rng)
    if init == "uniform":
        n = x_train.shape[1]
        return MLPWeights.from_vector(rng.uniform(-0.5, 0.5, n_weights(n, n_hidden)), n, n_hidden)
    raise ConfigError(f"init must be 'nguyen-widrow' or 'uniform', got {init!r}")


def fit(
    pairs: PairSet, method: Method = "lm", n_hidden: int = 5, seed: int = 0,
    settings: GDSettings | LMSettings | None = None, on_epoch: EpochCallback | None = None,
    provenance: dict | None = None, init: Init = "nguyen-widrow", starts: int = 1,
) -> FitResult:
    """Train one N-H-1 network on ``pairs`` (best of ``starts`` initial draws by validation MSE, module
    docstring); ``provenance`` goes into the model's metadata."""
    settings = _settings(method, settings)
    if n_hidden < 1:
        raise ConfigError(f"hidden size must be >= 1, got {n_hidden}")
    if starts < 1:
        raise ConfigError(f"starts must be >= 1, got {starts}")
    _check_pairs(pairs)
    split_rng, init_rng = _streams(seed)
    split = split_indices(len(pairs), split_rng)
    normaliser = Normaliser.fit(pairs.features[split.train])
    x = normaliser.transform(pairs.features)
    y = pairs.labels.astype(float)
    subsets = {name: Subset(x[rows], y[rows]) for name, rows in split.items()}
    trainer = train_gd if method == "gd" else train_lm
    result, seconds = None, 0.0
    for _ in range(starts):
        theta0 = initial_weights(init, x[split.train], n_hidden, init_rng)
        run = trainer(theta0.to_vector(), n_hidden, subsets["train"], subsets["validation"],
                      subsets["test"], settings, on_epoch)
        seconds += run.seconds
        if result is None or run.loss["validation"][run.best_epoch] < result.loss["validation"][result.best_epoch]:
            result = run
    result = replace(result, seconds=seconds)
    weights = MLPWeights.from_vector(result.theta, x.shape[1], n_hidden)
    scores = Scorer(weights, normaliser, pairs.feature_set)(pairs.features)  # as the model file will score
    metrics = {name: classifier_metrics(pairs.labels[rows], scores[rows]) for name, rows in split.items()}
    metrics["all"] = classifier_metrics(pairs.labels, scores)
    metadata = {
        "nnda_version": __version__,
        "method": method,
        "settings": asdict(settings),
        "seed": seed,
        "initialisation": init,
        "starts": starts,
        "epochs": result.epochs,
        "best_epoch": result.best_epoch,
        "stop_reason": result.stop_reason,
        "pairs": {"total": len(pairs), "own_contact": pairs.n_positive, "clutter": pairs.n_clutter,
                  "other_target": pairs.n_other_target, "datasets": len(pairs.names)},
        "split": {name: int(rows.size) for name, rows in split.items()},
        "normaliser_fitted_on": "train",
        "test_metrics": metrics["test"].as_dict(),
        **(provenance or {}),
    }
    scorer = Scorer(weights, normaliser, pairs.feature_set, metadata=metadata)
    return FitResult(method, seed, scorer, result, split, scores, metrics)


@dataclass(frozen=True)
class RunSummary:
    """The figures of one fit that tables aggregate over seeds."""

    method: Method
    n_inputs: int
    n_hidden: int
    seed: int
    init: Init
    metrics: dict[str, ClassifierMetrics]
    epochs: int
    best_epoch: int
    stop_reason: str
    seconds: float

    @classmethod
    def of(cls, result: FitResult) -> RunSummary:
        t = result.training
        return cls(result.method, result.scorer.weights.n_inputs, result.scorer.weights.n_hidden, result.seed,
                   result.scorer.metadata["initialisation"], result.metrics,
                   t.epochs, t.best_epoch, t.stop_reason, t.seconds)

    def as_dict(self) -> dict:
        return asdict(self)


RunCallback = Callable[[RunSummary], None]


def repeat(
    pairs: PairSet, methods: Sequence[Method] = METHODS, n_hidden: int = 5, seeds: Iterable[int] = range(10),
    on_run: RunCallback | None = None, init: Init = "nguyen-widrow",
) -> list[RunSummary]:
    """Fit every method once per seed (same split and start for all methods of a seed)."""
    runs = []
    for seed in seeds:
        for method in methods:
            runs.append(RunSummary.of(fit(pairs, method, n_hidden, seed, init=init)))
            if on_run is not None:
                on_run(runs[-1])
    return runs


@dataclass(frozen=True)
class SweepResult:
    """Hidden-size sweep: ``runs`` in size-major order, ``restarts`` per size."""

    method: Method
    hidden_sizes: tuple[int, ...]
    restarts: int
    runs: tuple[RunSummary, ...]

    def grid(self, value: Callable[[RunSummary], float]) -> np.ndarray:
        """``value`` of every run, shape (sizes, restarts)."""
        return np.array([value(r) for r in self.runs]).reshape(len(self.hidden_sizes), self.restarts)

    @property
    def test_mse(self) -> np.ndarray:
        return self.grid(lambda r: r.metrics["test"].mse)

    @property
    def best_size(self) -> int:
        """The hidden size with the lowest mean test MSE."""
        return self.hidden_sizes[int(np.argmin(self.test_mse.mean(axis=1)))]


def sweep(
    pairs: PairSet, hidden_sizes: Sequence[int] = tuple(range(1, 11)), restarts: int = 10,
    method: Method = "lm", seed: int = 0, on_run: RunCallback | None = None, init: Init = "nguyen-widrow",
) -> SweepResult:
    """``restarts`` fits per hidden size with seeds seed .. seed + restarts - 1."""
    if restarts < 1 or not hidden_sizes:
        raise ConfigError("a sweep needs at least one hidden size and one restart")
    runs = []
    for h in hidden_sizes:
        for r in range(restarts):
            runs.append(RunSummary.of(fit(pairs, method, h, seed + r, init=init)))
            if on_run is not None:
                on_run(runs[-1])
    return SweepResult(method, tuple(hidden_sizes), restarts, tuple(runs))
