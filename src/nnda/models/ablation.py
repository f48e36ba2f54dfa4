"""Feature ablation: which pair features buy how much classification.

The pairs are extracted once per data model (track history =
measured contacts, as in Vargas Avila (2015); or the targets' true positions) with the
extended set (`nnda.models.innovation.IMM_INNOVATION`); every variant then
trains on a subset of its columns, so all variants see the same pairs and,
for a given seed, the same split and the same random stream
(`nnda.models.experiment.fit`, by default best of 3 starts by validation
MSE, so that a start stalled in a saturated minimum does not stand for the
feature set). Variants:

* ``seed``: the thesis's three kinematic features (`nnda.models.features.KINEMATIC`);
* ``extended``: all nine;
* ``seed + <feature>``: those three and one added feature, for each of
  the six IMM features;
* ``IMM only``: the six IMM features without the kinematic three.

Per data model, the pairs are also described (`describe_pairs`): how many
there are and how many negatives fall inside the track's 99 % gate
(d^2 < 9.21), where a pair seen alone looks like the track's own contact.
Per variant and data model: test-split accuracy and AUC over the seeds
(mean and 95% bootstrap interval, `nnda.reports.classifier_tables.mean_interval`) and
the ROC averaged vertically over the seeds (mean sensitivity at fixed
false-positive rates of each seed's test split).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from nnda.data.dataset import Dataset
from nnda.filters.kalman import GATE_99
from nnda.models.features import KINEMATIC, FeatureSet
from nnda.models.innovation import ADDED_NAMES, IMM_INNOVATION
from nnda.models.metrics import roc
from nnda.models.pairs import History, PairSet, pairs_from_datasets

if TYPE_CHECKING:  # training imports torch; the file format and the variants do not need it
    from nnda.models.experiment import Init, Method, RunSummary

ABLATION_FORMAT = "nnda.ablation"
ABLATION_FORMAT_VERSION = 1
ABLATION_FILE = "ablation.json"
HISTORIES: tuple[History, ...] = ("measured", "true")
#: false-positive rates at which the ROC curves of the seeds are averaged
ROC_GRID = np.linspace(0.0, 1.0, 201)


def variants() -> dict[str, tuple[str, ...]]:
    """Variant label -> feature columns (module docstring)."""
    out = {"seed": KINEMATIC.names, "extended": IMM_INNOVATION.names}
    out.update({f"seed + {name}": KINEMATIC.names + (name,) for name in ADDED_NAMES})
    out["IMM only"] = ADDED_NAMES
    return out


def columns(pairs: PairSet, label: str, names: Sequence[str]) -> PairSet:
    """The pairs with only the feature columns ``names`` (of ``pairs.feature_set``), as an ad-hoc set."""
    index = [pairs.feature_set.names.index(n) for n in names]
    features = FeatureSet(f"ablation:{label}", 0, tuple(names), f"columns {', '.join(names)} of "
                          f"{pairs.feature_set.name}")
    return replace(pairs, features=pairs.features[:, index], feature_set=features)


@dataclass(frozen=True)
class VariantResult:
    """One variant under one data model: a run per (method, seed) and the mean test ROC per method."""

    history: History
    variant: str
    features: tuple[str, ...]
    runs: tuple[RunSummary, ...]
    roc_tpr: dict[str, np.ndarray]  # method -> (len(ROC_GRID),) mean sensitivity

    def as_dict(self) -> dict:
        return {"history": self.history, "variant": self.variant, "features": list(self.features),
                "runs": [r.as_dict() for r in self.runs],
                "roc": {"fpr": ROC_GRID.tolist(), "tpr": {m: v.tolist() for m, v in self.roc_tpr.items()}}}


def describe_pairs(pairs: PairSet) -> dict:
    """Counts of a pair set of the extended features: pairs, own contacts, negatives inside the 99 % gate."""
    d2 = pairs.features[:, pairs.feature_set.names.index("mahalanobis_d2")]
    negative = pairs.labels < 0
    inside = int(np.count_nonzero(negative & (d2 < GATE_99)))
    return {"pairs": len(pairs), "own_contact": pairs.n_positive, "negative": int(negative.sum()),
            "negative_in_gate": inside, "negative_in_gate_fraction_of_pairs": inside / max(len(pairs), 1),
            "own_outside_gate": int(np.count_nonzero(~negative & (d2 >= GATE_99)))}


def _tpr_on_grid(labels: np.ndarray, scores: np.ndarray) -> np.ndarray:
    fpr, tpr = roc(labels, scores)
    return np.interp(ROC_GRID, fpr, tpr)


def ablation(
    datasets: Iterable[Dataset], methods: Sequence[Method] = ("lm",), n_hidden: int = 5,
    seeds: Iterable[int] = range(10), init: Init = "nguyen-widrow", starts: int = 3,
    on_run: Callable[[str, str, RunSummary], None] | None = None,
) -> tuple[list[VariantResult], dict[str, dict]]:
    """Every variant x data model x method x seed (module docstring); ``on_run(history, variant, run)``.

    Returns the variants' results and `describe_pairs` of each data model's pairs.
    """
    from nnda.models.experiment import RunSummary, fit

    datasets, seeds = list(datasets), list(seeds)
    results, described = [], {}
    for history in HISTORIES:
        pairs = pairs_from_datasets(datasets, history=history, features=IMM_INNOVATION.name)
        described[history] = describe_pairs(pairs)
        for label, names in variants().items():
            subset = columns(pairs, label, names)
            runs, curves = [], {m: [] for m in methods}
            for seed in seeds:
                for method in methods:
                    result = fit(subset, method, n_hidden, seed, init=init, starts=starts)
                    runs.append(RunSummary.of(result))
                    test = result.split.test
                    curves[method].append(_tpr_on_grid(subset.labels[test], result.scores[test]))
                    if on_run is not None:
                        on_run(history, label, runs[-1])
            results.append(VariantResult(history, label, tuple(names), tuple(runs),
                                         {m: np.mean(c, axis=0) for m, c in curves.items()}))
    return results, described
