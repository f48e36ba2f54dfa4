"""PNG plots of the association network: ROC curves, loss per epoch, the hidden-size sweep, the ablation."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from nnda.extras import require  # noqa: E402
from nnda.models.metrics import roc  # noqa: E402

if TYPE_CHECKING:  # both import torch; plotting their results does not need it
    from nnda.models.experiment import SweepResult
    from nnda.models.trainers import TrainingResult


def _save(fig, out: str | Path, dpi: int) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def plot_roc(curves: dict[str, tuple[np.ndarray, np.ndarray]], out: str | Path, title: str = "ROC",
             dpi: int = 110) -> Path:
    """ROC (sensitivity against false-positive rate) of each named (labels, scores) pair of arrays."""
    auc = require("sklearn.metrics", "a ROC figure").roc_auc_score
    fig, ax = plt.subplots(figsize=(5.5, 5), constrained_layout=True)
    for name, (labels, scores) in curves.items():
        fpr, tpr = roc(labels, scores)
        ax.plot(fpr, tpr, lw=1.4, label=f"{name} (AUC {auc(labels, scores):.4f})")
    ax.plot([0, 1], [0, 1], ":", color="0.6", lw=1)
    ax.set(xlabel="false-positive rate", ylabel="sensitivity", title=title, xlim=(0, 1), ylim=(0, 1.01))
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    return _save(fig, out, dpi)


def plot_losses(result: TrainingResult, out: str | Path, title: str = "", dpi: int = 110) -> Path:
    """MSE per epoch of each subset (log scale), with the returned epoch marked."""
    fig, ax = plt.subplots(figsize=(6.5, 4.5), constrained_layout=True)
    for name, loss in result.loss.items():
        ax.plot(np.arange(loss.size), loss, lw=1.4, label=name)
    ax.axvline(result.best_epoch, color="0.4", ls="--", lw=1, label=f"best validation (epoch {result.best_epoch})")
    ax.set_yscale("log")
    ax.set(xlabel="epoch", ylabel="MSE",
           title=title or f"{result.method.upper()}: {result.epochs} epochs, stopped by {result.stop_reason}")
    ax.legend()
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, dpi)


def plot_sweep(result: SweepResult, out: str | Path, dpi: int = 110) -> Path:
    """Test MSE against hidden size: every restart as a dot, the mean as a line."""
    mse = result.test_mse
    sizes = np.array(result.hidden_sizes)
    fig, ax = plt.subplots(figsize=(6, 4.5), constrained_layout=True)
    ax.plot(np.repeat(sizes, result.restarts), mse.ravel(), ".", color="0.6", label="restart")
    ax.plot(sizes, mse.mean(axis=1), "o-", color="C0", label="mean")
    ax.set(xlabel="hidden units", ylabel="test MSE", xticks=sizes,
           title=f"Hidden-size sweep ({result.method.upper()}, {result.restarts} restarts)")
    ax.legend()
    ax.grid(alpha=0.3)
    return _save(fig, out, dpi)



#: the ablation variants drawn in the ROC panels (every variant is in the table)
ABLATION_CURVES = ("seed", "extended", "seed + mahalanobis_d2", "IMM only")


def plot_ablation_roc(results: Sequence[dict], out: str | Path | None = None, dpi: int = 110):
    """Mean test ROC over seeds of the main ablation variants, one panel per data model, each method.

    ``results`` are the ``results`` entries of ``ablation.json``. Saves to ``out`` and returns the path, or
    returns the figure when ``out`` is None.
    """
    histories = list(dict.fromkeys(r["history"] for r in results))
    fig, axes = plt.subplots(1, len(histories), figsize=(5.2 * len(histories), 5), constrained_layout=True,
                             squeeze=False)
    for ax, history in zip(axes[0], histories):
        for r in results:
            if r["history"] != history or r["variant"] not in ABLATION_CURVES:
                continue
            fpr = np.asarray(r["roc"]["fpr"])
            for method, tpr in r["roc"]["tpr"].items():
                ax.plot(fpr, tpr, lw=1.4, label=f"{r['variant']}, {method.upper()} (area {np.trapezoid(tpr, fpr):.4f})")
        ax.plot([0, 1], [0, 1], ":", color="0.6", lw=1)
        ax.set(xlabel="false-positive rate", ylabel="sensitivity", title=f"{history} track history",
               xlim=(0, 0.3), ylim=(0.7, 1.005))
        ax.legend(loc="lower right", fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle("Feature ablation: mean test ROC over seeds (zoomed)")
    return fig if out is None else _save(fig, out, dpi)
