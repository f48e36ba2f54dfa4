"""Result tables of the association network, printable (rich) and writable (Markdown).

Layouts follow the spec's Table 6.3 (rows TP, FN, TN, FP, sensitivity,
specificity, false-positive rate), extended by accuracy, AUC and MSE, and
for repeated runs by epochs and training time. Over repeated runs a cell
reads ``mean [lo, hi]``: the mean over seeds and a 95% percentile-bootstrap
confidence interval of that mean (10,000 resamples, fixed seed). The
bootstrap keeps the interval inside the range of the runs, which a Student t
interval does not when a few runs end in a poor local minimum (bounded
rates would get intervals past 1); median rows show the typical run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from rich.table import Table

from nnda.models.metrics import SPEC_TABLE_6_3, ClassifierMetrics

if TYPE_CHECKING:  # the experiment module imports torch; tables are also made without it
    from nnda.models.experiment import FitResult, RunSummary, SweepResult

#: (row label, metric field, format) of the Table 6.3 layout plus accuracy, AUC and MSE
MEASURES = (
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


@dataclass(frozen=True)
class TextTable:
    """A titled table of strings, with an optional note printed under it."""

    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    note: str = ""

    def rich(self) -> Table:
        table = Table(title=self.title, caption=self.note or None, caption_justify="left")
        for i, name in enumerate(self.header):
            table.add_column(name, justify="left" if i == 0 else "right")
        for row in self.rows:
            table.add_row(*row)
        return table

    def markdown(self) -> str:
        lines = [f"### {self.title}", "", "| " + " | ".join(self.header) + " |",
                 "|" + "|".join(["---"] + ["---:"] * (len(self.header) - 1)) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in self.rows]
        if self.note:
            lines += ["", self.note]
        return "\n".join(lines) + "\n"


def _spec(method: str, key: str, fmt: str) -> str:
    value = SPEC_TABLE_6_3[method].get(key)
    return "" if value is None else fmt.format(value)


def metrics_table(
    title: str, columns: dict[str, ClassifierMetrics], spec_method: str | None = None, note: str = "",
) -> TextTable:
    """Measures (rows) of each named subset (columns), optionally beside the spec's Table 6.3 column."""
    header = ("Measure", *columns)
    if spec_method is not None:
        header += (f"spec {spec_method.upper()} (all)",)
    rows = []
    for label, key, fmt in MEASURES:
        row = [label, *(fmt.format(getattr(m, key)) for m in columns.values())]
        if spec_method is not None:
            row.append(_spec(spec_method, key, fmt))
        rows.append(tuple(row))
    return TextTable(title, header, tuple(rows), note)


def fit_table(result: FitResult) -> TextTable:
    """The metrics of one trained model on each subset, beside the spec's figures for its method."""
    t = result.training
    note = (f"{t.epochs} epochs (weights of epoch {t.best_epoch}), stopped by {t.stop_reason}, "
            f"{t.seconds:.3f} s; spec: {SPEC_TABLE_6_3[result.method]['epochs']} epochs")
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
    means = v[np.random.default_rng(0).integers(0, v.size, (resamples, v.size))].mean(axis=1)
    lo, hi = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return mean, float(lo), float(hi)


def _cell(values: Sequence[float], fmt: str) -> str:
    mean, lo, hi = mean_interval(values)
    return f"{fmt.format(mean)} [{fmt.format(lo)}, {fmt.format(hi)}]"


def repeats_table(runs: Sequence[RunSummary]) -> TextTable:
    """GD and LM over seeds: test split and all pairs, beside the spec's Table 6.3 (all pairs)."""
    methods = [m for m in ("gd", "lm") if any(r.method == m for r in runs)]
    by_method = {m: [r for r in runs if r.method == m] for m in methods}
    columns = [(m, subset) for subset in ("test", "all") for m in methods]
    header = ("Measure", *(f"{m.upper()}, {s}" for m, s in columns), *(f"spec {m.upper()}" for m in methods))
    rows = []
    for label, key, fmt in MEASURES:
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
            + ". Spec values are Table 6.3 (one run, all 2766 pairs).")
    return TextTable("Classifier results over seeds (spec Table 6.3 layout)", header, tuple(rows), note)


def sweep_table(result: SweepResult) -> TextTable:
    """Mean and std of the test MSE per hidden size (spec A23), with test accuracy and epochs."""
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
            f"and initialisation; every variant trains on the same pairs and splits. 'measured' history: the spec's "
            f"data model (track = measured contacts); 'true': the targets' true positions (spec §14.1). Thesis "
            f"(one run, all pairs): GD 0.941 / 0.979, LM 0.992 / 0.9981.")
    return TextTable(f"Feature ablation, {METHOD_NAMES[method]}", header, tuple(rows), note)
