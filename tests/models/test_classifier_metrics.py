from __future__ import annotations

import numpy as np
import pytest

from nnda.errors import ModelError
from nnda.models.metrics import classifier_metrics, roc
from nnda.reports.classifier_tables import mean_interval, metrics_table


def test_confusion_counts_and_rates_by_hand():
    labels = np.array([1, 1, 1, 1, -1, -1, -1, -1, -1, -1])
    scores = np.array([0.9, 0.2, -0.1, 0.5, -0.8, -0.3, 0.4, -0.9, 0.0, -0.2])  # 0.0 is not > 0
    m = classifier_metrics(labels, scores)
    assert (m.tp, m.fn, m.tn, m.fp) == (3, 1, 5, 1)
    assert m.sensitivity == 0.75 and m.specificity == 5 / 6 and m.fpr == 1 / 6
    assert m.accuracy == 0.8 and m.n == 10
    # AUC = share of (positive, negative) pairs ranked correctly: 21 of 24 here
    assert m.auc == pytest.approx(21 / 24)
    assert m.mse == pytest.approx(np.mean((scores - labels) ** 2))


def test_roc_runs_from_corner_to_corner():
    fpr, tpr = roc(np.array([1, -1, 1, -1]), np.array([0.9, 0.1, 0.4, 0.6]))
    assert (fpr[0], tpr[0], fpr[-1], tpr[-1]) == (0.0, 0.0, 1.0, 1.0)


def test_one_class_has_no_auc_and_bad_labels_are_refused():
    assert np.isnan(classifier_metrics(np.array([-1, -1]), np.array([-0.5, 0.5])).auc)
    with pytest.raises(ModelError, match="labels must be -1 or \\+1"):
        classifier_metrics(np.array([0, 1]), np.array([0.1, 0.2]))
    with pytest.raises(ModelError, match="non-finite"):
        classifier_metrics(np.array([-1, 1]), np.array([np.nan, 0.2]))


def test_mean_interval_is_a_bootstrap_interval_inside_the_runs():
    values = [0.94] * 18 + [0.70, 0.95]  # one run in a poor local minimum
    mean, lo, hi = mean_interval(values)
    assert mean == pytest.approx(0.9285)
    assert 0.70 <= lo < mean < hi <= 0.95
    assert mean_interval(values) == (mean, lo, hi)  # seeded
    # for well-behaved data it agrees with the normal-theory interval
    v = np.random.default_rng(3).normal(10.0, 2.0, 400)
    _, lo, hi = mean_interval(v)
    half = 1.96 * v.std(ddof=1) / np.sqrt(v.size)
    assert (lo, hi) == pytest.approx((v.mean() - half, v.mean() + half), abs=0.03)


def test_metrics_table_has_the_table_6_3_rows_and_the_spec_column():
    m = classifier_metrics(np.array([1, -1, 1, -1]), np.array([0.9, -0.1, 0.4, 0.6]))
    table = metrics_table("t", {"test": m}, spec_method="lm")
    assert [r[0] for r in table.rows[:7]] == ["TP", "FN", "TN", "FP", "Sensitivity", "Specificity", "FPR"]
    assert table.rows[0] == ("TP", "2", "824")
    assert "| Accuracy | 0.7500 | 0.9920 |" in table.markdown()
