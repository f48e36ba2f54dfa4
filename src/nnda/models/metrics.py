"""Classifier metrics of the association network (as in Vargas Avila (2015), eqs. 6.1-6.3), via scikit-learn.

The positive class is "the track's own contact" (label +1); a score > 0
predicts it. The ROC sweeps the threshold over the scores.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from nnda.errors import ModelError
from nnda.extras import require


@dataclass(frozen=True)
class ClassifierMetrics:
    """Confusion counts and rates of one subset; ``auc`` is NaN when it holds one class only."""

    tp: int
    fn: int
    tn: int
    fp: int
    sensitivity: float
    specificity: float
    fpr: float
    accuracy: float
    auc: float
    mse: float

    @property
    def n(self) -> int:
        return self.tp + self.fn + self.tn + self.fp

    def as_dict(self) -> dict:
        return asdict(self)


#: Vargas Avila (2015), Table 6.3: totals over all 2766 pairs, one run per method.
PUBLISHED_TABLE_6_3 = {
    "gd": {"tp": 784, "fn": 47, "tn": 1819, "fp": 116, "sensitivity": 0.9434, "specificity": 0.94,
           "fpr": 0.0599, "accuracy": 0.941, "auc": 0.979, "epochs": 1000},
    "lm": {"tp": 824, "fn": 7, "tn": 1919, "fp": 16, "sensitivity": 0.9916, "specificity": 0.9917,
           "fpr": 0.0083, "accuracy": 0.992, "auc": 0.9981, "epochs": 35},
}


def _ratio(num: int, den: int) -> float:
    return num / den if den else float("nan")


def _check(labels: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    labels, scores = np.asarray(labels), np.asarray(scores, dtype=float)
    if labels.shape != scores.shape or labels.ndim != 1 or labels.size == 0:
        raise ModelError(f"metrics: labels and scores must be non-empty (N,) arrays, got "
                         f"{labels.shape} and {scores.shape}")
    if not np.isin(labels, (-1, 1)).all():
        raise ModelError("metrics: labels must be -1 or +1")
    if not np.isfinite(scores).all():
        raise ModelError("metrics: scores hold non-finite values")
    return labels, scores


def classifier_metrics(labels: np.ndarray, scores: np.ndarray, threshold: float = 0.0) -> ClassifierMetrics:
    """Metrics of scores (N,) against labels (N,) in {-1, +1}; predicted positive when score > threshold."""
    labels, scores = _check(labels, scores)
    predicted = np.where(scores > threshold, 1, -1)
    sk = require("sklearn.metrics", "a classifier's metrics")
    tn, fp, fn, tp = (int(v) for v in sk.confusion_matrix(labels, predicted, labels=[-1, 1]).ravel())
    auc = float(sk.roc_auc_score(labels, scores)) if np.unique(labels).size == 2 else float("nan")
    return ClassifierMetrics(
        tp=tp, fn=fn, tn=tn, fp=fp,
        sensitivity=_ratio(tp, tp + fn), specificity=_ratio(tn, tn + fp), fpr=_ratio(fp, tn + fp),
        accuracy=(tp + tn) / labels.size, auc=auc, mse=float(np.mean((scores - labels) ** 2)),
    )


def roc(labels: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ROC curve: (false-positive rate, sensitivity) arrays as the threshold sweeps the scores."""
    labels, scores = _check(labels, scores)
    fpr, tpr, _ = require("sklearn.metrics", "a ROC curve").roc_curve(labels, scores, pos_label=1)
    return fpr, tpr
