"""Picture of a dataset: radar coverage, clutter, target contacts and true tracks."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from nnda.data.dataset import Dataset  # noqa: E402


def plot_scenario(dataset: Dataset, out: str | Path, dpi: int = 120) -> Path:
    """Write a PNG with the whole coverage (left) and a zoom on the targets (right).

    Grey dots are clutter of every scan, coloured dots each target's contacts,
    lines the true tracks (a circle marks each start); dashed circles are the
    radar's minimum and maximum range. Axes in km, x east, y north.
    """
    det, truth, sc = dataset.detections, dataset.truth, dataset.scenario
    fig, axes = plt.subplots(1, 2, figsize=(14, 7), constrained_layout=True)
    km = 1e-3
    colours = plt.get_cmap("tab10")
    for ax in axes:
        clutter = det.is_clutter
        ax.scatter(det.x[clutter] * km, det.y[clutter] * km, s=1, c="0.7", lw=0, label="clutter", rasterized=True)
        for tid, target in enumerate(sc.targets):
            c = colours(tid % 10)
            mine = det.target_id == tid
            ax.scatter(det.x[mine] * km, det.y[mine] * km, s=6, color=c, lw=0)
            rows = truth.target_id == tid
            ax.plot(truth.x[rows] * km, truth.y[rows] * km, color=c, lw=1.2,
                    label=f"{target.name} ({mine.sum()} contacts)")
            if rows.any():
                first = np.flatnonzero(rows)[0]
                ax.plot(truth.x[first] * km, truth.y[first] * km, "o", mfc="none", color=c)
        for radius in (sc.sensor.min_range_m, sc.sensor.max_range_m):
            ax.add_patch(plt.Circle((0, 0), radius * km, fill=False, ls="--", color="k", lw=0.8))
        ax.plot(0, 0, "k^", ms=8)
        ax.set_aspect("equal")
        ax.set_xlabel("x east (km)")
        ax.set_ylabel("y north (km)")
        ax.grid(alpha=0.3)
    reach = sc.sensor.max_range_m * km * 1.05
    axes[0].set(xlim=(-reach, reach), ylim=(-reach, reach), title="radar coverage")
    pad = 2.0
    axes[1].set(xlim=(truth.x.min() * km - pad, truth.x.max() * km + pad),
                ylim=(truth.y.min() * km - pad, truth.y.max() * km + pad), title="targets (zoom)")
    axes[1].legend(loc="best", fontsize=8, markerscale=4)
    n_clutter = int(det.is_clutter.sum())
    fig.suptitle(f"{sc.name}: {sc.n_scans} scans of {sc.sensor.scan_period_s:g} s, "
                 f"{n_clutter} clutter points ({n_clutter / sc.n_scans:.0f}/scan), seed {dataset.seed}, "
                 f"run {dataset.run}")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, metadata={"Software": None})
    plt.close(fig)
    return out
