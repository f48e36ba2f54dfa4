"""Tables of the association network: ``nnda train`` / ``nnda evaluate``'s and the study report's.

Layouts follow Vargas Avila (2015), Table 6.3 (rows TP, FN, TN, FP, sensitivity,
specificity, false-positive rate), extended by accuracy, AUC and MSE, and
for repeated runs by epochs and training time. Over repeated runs a cell
reads ``mean [lo, hi]``: the mean over seeds and a 95% percentile-bootstrap
confidence interval of that mean (10,000 resamples, fixed seed). The
bootstrap keeps the interval inside the range of the runs, which a Student t
interval does not when a few runs end in a poor local minimum (bounded
rates would get intervals past 1); median rows show the typical run. The
study report's two tables (`classifier_table`, `model_test_table`) read the
model figures of ``classifier.json`` (`nnda.study.classifier`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from nnda.models.features import KINEMATIC
from nnda.models.metrics import PUBLISHED_TABLE_6_3, ClassifierMetrics
from nnda.reports.text_table import DASH, TextTable, interval
from nnda.study.stats import bootstrap_indices, percentile_interval

if TYPE_CHECKING:  # the experiment module imports torch; tables are also made without it
    from nnda.models.experiment import FitResult, RunSummary, SweepResult

#: (row label, metric field, format) of the Table 6.3 layout plus accuracy, AUC and MSE
CLASSIFIER_MEASURES = (
    ("TP", "tp", "{:.0f}"),
    ("FN", "fn", "{:.0f}"),
    ("TN", "tn", "{:.0f}"),
    ("FP", "fp", "{:.0f}"),
    ("Sensitivity", "sensitivity", "{:.4f}"),
    ("Specificity", "specificity", "{:.4f}"),
    ("FPR", "fpr", "{:.4f}"),
    ("Accuracy", "accuracy", "{:.4f}"),
    ("AUC", "auc", "{:.4f}"),
    ("MSE", "mse", "{:.4f}"),
)
METHOD_NAMES = {"gd": "Gradient descent", "lm": "Levenberg-Marquardt"}


def _spec(method: str, key: str, fmt: str) -> str:
    value = PUBLISHED_TABLE_6_3[method].get(key)
    return "" if value is None else fmt.format(value)


def metrics_table(
    title: str, columns: dict[str, ClassifierMetrics], spec_method: str | None = None, note: str = "",
) -> TextTable:
    """Measures (rows) of each named subset (columns), optionally beside the thesis's Table 6.3 column."""
    header = ("Measure", *columns)
    if spec_method is not None:
        header += (f"thesis {spec_method.upper()} (all)",)
    rows = []
    for label, key, fmt in CLASSIFIER_MEASURES:
        row = [label, *(fmt.format(getattr(m, key)) for m in columns.values())]
        if spec_method is not None:
            row.append(_spec(spec_method, key, fmt))
        rows.append(tuple(row))
    return TextTable(title, header, tuple(rows), note)


def fit_table(result: FitResult) -> TextTable:
    """The metrics of one trained model on each subset, beside the thesis's figures for its method."""
    t = result.training
    note = (f"{t.epochs} epochs (weights of epoch {t.best_epoch}), stopped by {t.stop_reason}, "
            f"{t.seconds:.3f} s; thesis: {PUBLISHED_TABLE_6_3[result.method]['epochs']} epochs")
    n = result.scorer.weights.n_hidden
    title = f"{METHOD_NAMES[result.method]}, {result.scorer.weights.n_inputs}-{n}-1 tanh on " \
            f"{result.scorer.features.name}, seed {result.seed}"
    return metrics_table(title, result.metrics, result.method, note)


def mean_interval(values: Sequence[float], level: float = 0.95, resamples: int = 10_000) -> tuple[float, float, float]:
    """Mean of ``values`` and its ``level`` percentile-bootstrap confidence interval (seeded, deterministic)."""
    v = np.asarray(values, dtype=float)
    mean = float(v.mean())
    if v.size < 2:
        return mean, float("nan"), float("nan")
    means = v[bootstrap_indices(0, v.size, resamples)].mean(axis=1)
    return mean, *percentile_interval(means, level)


def _cell(values: Sequence[float], fmt: str) -> str:
    return interval(*mean_interval(values), fmt)


def repeats_table(runs: Sequence[RunSummary]) -> TextTable:
    """GD and LM over seeds: test split and all pairs, beside the thesis's Table 6.3 (all pairs)."""
    methods = [m for m in ("gd", "lm") if any(r.method == m for r in runs)]
    by_method = {m: [r for r in runs if r.method == m] for m in methods}
    columns = [(m, subset) for subset in ("test", "all") for m in methods]
    header = ("Measure", *(f"{m.upper()}, {s}" for m, s in columns), *(f"thesis {m.upper()}" for m in methods))
    rows = []
    for label, key, fmt in CLASSIFIER_MEASURES:
        mean_fmt = "{:.1f}" if fmt == "{:.0f}" else fmt  # mean counts get one decimal
        row = [label, *(_cell([getattr(r.metrics[s], key) for r in by_method[m]], mean_fmt)
                        for m, s in columns)]
        rows.append((*row, *(_spec(m, key, fmt) for m in methods)))
    for label, key in (("Accuracy, median run", "accuracy"), ("AUC, median run", "auc")):
        rows.append((label, *(f"{np.median([getattr(r.metrics[s], key) for r in by_method[m]]):.4f}"
                              for m, s in columns), *("" for _ in methods)))
    extra: list[tuple[str, Callable[[RunSummary], float], str, str]] = [
        ("Epochs run", lambda r: r.epochs, "{:.1f}", "epochs"),
        ("Best-validation epoch", lambda r: r.best_epoch, "{:.1f}", ""),
        ("Training time (s)", lambda r: r.seconds, "{:.3f}", ""),
    ]
    for label, value, fmt, key in extra:
        row = [label]
        for m, s in columns:
            row.append(_cell([value(r) for r in by_method[m]], fmt) if s == "test" else "")
        row += [_spec(m, key, "{:.0f}") if key else "" for m in methods]
        rows.append(tuple(row))
    n = {m: len(v) for m, v in by_method.items()}
    shapes = sorted({f"{r.n_inputs}-{r.n_hidden}-1" for r in runs})
    stops = {m: sorted({r.stop_reason for r in by_method[m]}) for m in methods}
    inits = sorted({r.init for r in runs})
    counts = ", ".join(f"{n[m]} {m.upper()}" for m in methods)
    note = (f"Mean [95% bootstrap confidence interval of the mean] over {counts} "
            f"seeds of split and initialisation ({'/'.join(inits)}); {'/'.join(shapes)} tanh. "
            "Stop reasons: "
            + "; ".join(f"{m.upper()} {', '.join(stops[m])}" for m in methods)
            + ". Thesis values: Vargas Avila (2015), Table 6.3 (one run, all 2766 pairs).")
    return TextTable("Classifier results over seeds (Table 6.3 layout)", header, tuple(rows), note)


def sweep_table(result: SweepResult) -> TextTable:
    """Mean and std of the test MSE per hidden size, with test accuracy and epochs."""
    mse = result.test_mse
    acc = result.grid(lambda r: r.metrics["test"].accuracy)
    epochs = result.grid(lambda r: r.epochs)
    rows = []
    for i, h in enumerate(result.hidden_sizes):
        rows.append((str(h), f"{mse[i].mean():.4f}", f"{mse[i].std(ddof=1) if result.restarts > 1 else 0:.4f}",
                     f"{np.median(mse[i]):.4f}", f"{acc[i].mean():.4f}", f"{epochs[i].mean():.1f}",
                     "best" if h == result.best_size else ""))
    note = (f"{METHOD_NAMES[result.method]}, {result.restarts} restarts per size (seeds of split and "
            f"initialisation shared across sizes); best = lowest mean test MSE.")
    return TextTable("Hidden-size sweep", ("Hidden units", "Test MSE mean", "Test MSE std", "Test MSE median",
                                           "Test accuracy mean", "Epochs mean", ""), tuple(rows), note)


def ablation_table(results: Sequence[dict], method: str) -> TextTable:
    """Feature ablation of one training method: test accuracy and AUC per variant (rows) under each data
    model (columns), mean [95% bootstrap interval] over seeds. ``results`` are the ``results`` entries of
    ``ablation.json`` (`nnda.models.ablation.VariantResult.as_dict`)."""
    histories = list(dict.fromkeys(r["history"] for r in results))
    labels = list(dict.fromkeys(r["variant"] for r in results))
    tests = {(r["history"], r["variant"]): [run["metrics"]["test"] for run in r["runs"] if run["method"] == method]
             for r in results}
    inputs = {r["variant"]: len(r["features"]) for r in results}
    header = ("Features", "Inputs", *(f"{what} ({h} history)" for h in histories for what in ("Accuracy", "AUC")))
    rows = []
    for label in labels:
        row = [label, str(inputs[label])]
        for h in histories:
            row += [_cell([m["accuracy"] for m in tests[(h, label)]], "{:.4f}"),
                    _cell([m["auc"] for m in tests[(h, label)]], "{:.4f}")]
        rows.append(tuple(row))
    n = len(next(iter(tests.values())))
    note = (f"{METHOD_NAMES[method]}, test split, mean [95% bootstrap interval of the mean] over {n} seeds of split "
            f"and initialisation; every variant trains on the same pairs and splits. 'measured' history: the thesis's "
            f"data model (track = measured contacts); 'true': the targets' true positions. Vargas Avila (2015) "
            f"(one run, all pairs): GD 0.941 / 0.979, LM 0.992 / 0.9981.")
    return TextTable(f"Feature ablation, {METHOD_NAMES[method]}", header, tuple(rows), note)


def classifier_table(models: list[dict]) -> TextTable:
    """Table 6.3 layout: each model over all its training pairs, beside the thesis's GD and LM columns."""
    header = ("Measure", *(f"{m['label']} (all pairs)" for m in models), "thesis GD", "thesis LM")
    rows = []
    for label, key, fmt in CLASSIFIER_MEASURES:
        row = [label]
        for m in models:
            value = m["evaluation"]["metrics"].get(key)
            row.append(DASH if value is None else fmt.format(value))
        for method in ("gd", "lm"):
            value = PUBLISHED_TABLE_6_3[method].get(key)
            row.append(DASH if value is None else fmt.format(value))
        rows.append(tuple(row))
    extra = (("Method", lambda m: METHOD_NAMES.get(m["method"], str(m["method"] or DASH))),
             ("Features", lambda m: str(m.get("features", KINEMATIC.name))),
             ("Hidden units", lambda m: str(m["n_hidden"])),
             ("Epochs (best)", lambda m: f"{m['epochs']} ({m['best_epoch']})" if m["epochs"] is not None else DASH),
             ("Stopped by", lambda m: str(m["stop_reason"] or DASH)),
             ("Pairs (own contact)", lambda m: f"{m['evaluation']['n_pairs']} ({m['evaluation']['n_positive']})"))
    spec_extra = {"Method": ("Gradient descent", "Levenberg-Marquardt"),
                  "Features": (KINEMATIC.name, KINEMATIC.name), "Hidden units": ("5", "5"),
                  "Epochs (best)": ("1000", "35"), "Stopped by": (DASH, DASH),
                  "Pairs (own contact)": ("2766 (831)", "2766 (831)")}
    for label, get in extra:
        rows.append((label, *(get(m) for m in models), *spec_extra[label]))
    sources = "; ".join(f"{m['label']}: {m['evaluation']['pairs_from']}" for m in models)
    note = f"Scores of every pair of the models' training data. Pairs: {sources}."
    return TextTable("Association network (layout of the thesis's Table 6.3)", header, tuple(rows), note)


def model_test_table(models: list[dict]) -> TextTable:
    """The test-split metrics each model file records about itself."""
    header = ("Measure", *(f"{m['label']} (test split)" for m in models))
    rows = []
    for label, key, fmt in CLASSIFIER_MEASURES:
        row = [label]
        for m in models:
            value = (m.get("test_metrics") or {}).get(key)
            row.append(DASH if value is None else fmt.format(value))
        rows.append(tuple(row))
    return TextTable("As recorded in the model files (test split)", header, tuple(rows))
