"""Static figures of a study report (PNG bytes): time per scan, metrics over time, target count, ROC.

Each function returns the PNG as bytes; the report writes them to files
for ``report.md`` and embeds them as base64 in ``report.html``.
"""

from __future__ import annotations

import io
import warnings

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402

from nnda.study.measures import TIME, measure  # noqa: E402


def _png(fig, dpi: int = 100) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def _colours(trackers: list[str]) -> dict[str, tuple]:
    cmap = plt.get_cmap("tab10")
    return {t: cmap(i % 10) for i, t in enumerate(trackers)}


def time_per_scan(times: dict[tuple[str, str], np.ndarray], scenarios: list[str], trackers: list[str]) -> bytes:
    """Box plot of the time per scan (ms, log scale): a group per scenario, a box per tracker.

    ``times[(scenario, tracker)]`` holds every scan's time (s) over all runs.
    Boxes span the quartiles, whiskers the 5th-95th percentiles.
    """
    colours = _colours(trackers)
    width = 0.8 / len(trackers)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(scenarios) * max(1, len(trackers)) / 2 + 3), 4.5),
                           constrained_layout=True)
    for j, tracker in enumerate(trackers):
        data = [np.asarray(times[s, tracker]) * TIME.scale for s in scenarios]
        pos = np.arange(len(scenarios)) + (j - (len(trackers) - 1) / 2) * width
        box = ax.boxplot(data, positions=pos, widths=width * 0.85, whis=(5, 95), showfliers=False,
                         patch_artist=True, medianprops={"color": "k"})
        for patch in box["boxes"]:
            patch.set_facecolor(colours[tracker])
            patch.set_alpha(0.75)
        ax.plot([], [], "s", color=colours[tracker], label=tracker)
    ax.set_yscale("log")
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    ax.yaxis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(plain)
    ax.set_xticks(np.arange(len(scenarios)), scenarios)
    ax.set(ylabel=f"{TIME.label.lower()} ({TIME.unit}, log scale)",
           title=f"{TIME.label} (box: quartiles, whiskers: 5-95%)")
    ax.grid(alpha=0.3, which="both", axis="y")
    ax.legend(loc="best", fontsize=8)
    return _png(fig)


#: the per-scan measures of the over-time figure's first three panels (registry keys)
OVER_TIME = ("gospa", "ospa", "false_tracks_per_scan")


def over_time(scenario: dict, scan_times: np.ndarray, cutoff_m: float) -> bytes:
    """Per-scan means over runs of one ``summary.json`` scenario: GOSPA, OSPA, false tracks present, and
    the GOSPA missed and false parts as counts (part / (c²/2))."""
    trackers = list(scenario["trackers"])
    colours = _colours(trackers)
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.5), sharex=True, constrained_layout=True)
    panels = [measure(k) for k in OVER_TIME]
    missed, false = measure("gospa_missed"), measure("gospa_false")
    half_c2 = cutoff_m**2 / 2
    for name, t in scenario["trackers"].items():
        s = {k: np.array([np.nan if v is None else v for v in series]) for k, series in t["series_mean"].items()}
        time = scan_times[:s[panels[0].series_name].size]
        c = colours[name]
        for ax, m in zip(axes.ravel(), panels):
            ax.plot(time, s[m.series_name], color=c, lw=1.3, label=name)
        axes[1, 1].plot(time, s[missed.series_name] / half_c2, color=c, lw=1.3, label=f"{name} missed")
        axes[1, 1].plot(time, s[false.series_name] / half_c2, color=c, lw=1.1, ls="--", label=f"{name} false")
    for ax, m in zip(axes.ravel(), panels):
        ax.set(ylabel=f"{m.label} ({m.unit})" if m.unit else m.label.lower(), title=m.label)
    axes[0, 0].set_title(f"{panels[0].label} (c = {cutoff_m:g} m, p = 2, alpha = 2)")
    axes[1, 0].set(xlabel="time (s)")
    axes[1, 1].set(ylabel="per scan", xlabel="time (s)",
                   title="GOSPA: missed targets (solid), false tracks (dashed)")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{scenario['name']}: mean over {max(t['runs'] for t in scenario['trackers'].values())} run(s)")
    return _png(fig)


def run_band(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per scan of a (runs, scans) array: the mean over runs and the 2.5 and 97.5 percentiles (the central
    95% of runs); NaN entries (shorter runs) left out, all-NaN scans NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        low, high = np.nanpercentile(a, [2.5, 97.5], axis=0)
        return np.nanmean(a, axis=0), low, high


def target_count(name: str, scan_times: np.ndarray, counts: dict, trackers: list[str]) -> bytes:
    """Estimated target count over time in one scenario: each tracker's confirmed tracks (left) and, when
    some tracker reports it, the filter's own expected count (right); mean over runs (line) and the central
    95% of runs (band), the true count in black. ``counts`` maps labels to `nnda.study.cardinality.Counts`;
    ``trackers`` is the study's order (the colours of the other figures)."""
    colours = _colours(trackers)
    own = {t: c for t, c in counts.items() if c.filter_mean is not None}
    fig, axes = plt.subplots(1, 2 if own else 1, figsize=(12 if own else 7, 4.5), squeeze=False, sharey=True,
                             constrained_layout=True)
    panels = [(axes[0, 0], {t: c.confirmed for t, c in counts.items()}, "confirmed tracks")]
    if own:
        panels.append((axes[0, 1], {t: c.filter_mean for t, c in own.items()}, "filter's own expected count"))
    true = next(iter(counts.values())).true
    for ax, series, title in panels:
        for t, a in series.items():
            mean, low, high = run_band(a)
            time = scan_times[:mean.size]
            ax.fill_between(time, low, high, color=colours[t], alpha=0.15, lw=0)
            ax.plot(time, mean, color=colours[t], lw=1.3, label=t)
        truth = run_band(true)[0]
        ax.step(scan_times[:truth.size], truth, where="mid", color="k", lw=1.6, label="true count")
        ax.set(xlabel="time (s)", ylabel="targets", title=title)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    runs = max(c.runs for c in counts.values())
    fig.suptitle(f"{name}: target count, mean over {runs} run(s) and the central 95% of runs")
    return _png(fig)


def ablation_roc(results: list[dict]) -> bytes:
    """Mean test ROC of the main feature-ablation variants under both data models, from ``ablation.json``."""
    from nnda.models.plots import plot_ablation_roc  # loads scikit-learn, which only this figure needs

    return _png(plot_ablation_roc(results))


def roc_curves(models: list[dict]) -> bytes:
    """ROC of each model over all its training pairs, from ``classifier.json``."""
    fig, ax = plt.subplots(figsize=(5.5, 5), constrained_layout=True)
    for m in models:
        auc = m["evaluation"]["metrics"].get("auc")
        label = f"{m['label']} (AUC {auc:.4f})" if auc is not None else m["label"]
        ax.plot(m["roc"]["fpr"], m["roc"]["tpr"], lw=1.4, label=label)
    ax.plot([0, 1], [0, 1], ":", color="0.6", lw=1)
    ax.set(xlabel="false-positive rate", ylabel="sensitivity", title="ROC over all training pairs",
           xlim=(0, 1), ylim=(0, 1.01))
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    return _png(fig)
