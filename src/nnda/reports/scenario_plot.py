"""Picture of a dataset: every sensor's position and coverage, clutter, target contacts and true tracks."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Patch, Wedge  # noqa: E402

from nnda.data.dataset import Dataset  # noqa: E402
from nnda.data.occlusion import hidden  # noqa: E402
from nnda.data.scenario import Sensor  # noqa: E402
from nnda.files import atomic_output  # noqa: E402
from nnda.reports.trajectory_plot import edge_arrows, outside, robust_range  # noqa: E402

KM = 1e-3


def coverage_patches(sensor: Sensor, colour: str = "k") -> list[Patch]:
    """Outline of a sensor's coverage in km (x east, y north): its two range circles, or its sector wedge.

    A sector of width fov_deg about boresight_deg (clockwise from north) is a
    matplotlib `Wedge`, whose angles run counter-clockwise from east:
    theta = 90 - azimuth.
    """
    centre = (sensor.x_m * KM, sensor.y_m * KM)
    style = dict(fill=False, ls="--", color=colour, lw=0.8)
    if sensor.full_circle:
        return [Circle(centre, r * KM, **style) for r in (sensor.min_range_m, sensor.max_range_m)]
    theta = (90.0 - sensor.boresight_deg) % 360.0
    half = sensor.fov_deg / 2
    return [Wedge(centre, sensor.max_range_m * KM, theta - half, theta + half,
                  width=(sensor.max_range_m - sensor.min_range_m) * KM, **style)]


def _outline(sensor: Sensor) -> np.ndarray:
    """Points (2, n) in m bounding a sensor's coverage: the ring's extremes, or the sector's arc and apex."""
    if sensor.full_circle:
        az = np.radians(np.arange(0.0, 360.0, 90.0))  # the ring's extreme points
    else:
        az = np.radians(sensor.boresight_deg + np.linspace(-sensor.fov_deg / 2, sensor.fov_deg / 2, 361))
    x = np.append(sensor.x_m + sensor.max_range_m * np.sin(az), sensor.x_m)
    y = np.append(sensor.y_m + sensor.max_range_m * np.cos(az), sensor.y_m)
    return np.stack([x, y])


def hidden_from(dataset: Dataset) -> list[np.ndarray]:
    """Per sensor, a mask of the truth rows (M,) of its sweeps in which a nearer, longer ship hides the
    target from it (`nnda.data.occlusion`, on the true positions)."""
    sc, truth = dataset.scenario, dataset.truth
    lengths = np.array([t.length_m or 0.0 for t in sc.targets])[truth.target_id]
    sweep = dataset.scan_sensor[truth.scan - 1]
    out = []
    for j, sensor in enumerate(sc.sensors):
        rows = sweep == j
        mask = np.zeros(truth.scan.size, bool)
        mask[rows] = hidden(sensor.position, truth.scan[rows], truth.x[rows], truth.y[rows], lengths[rows])
        out.append(mask)
    return out


def _timing(dataset: Dataset) -> str:
    sc = dataset.scenario
    if len(sc.sensors) == 1:
        return f"{sc.n_scans} scans of {sc.sensors[0].scan_period_s:g} s"
    periods = ", ".join(f"{s.name} {s.scan_period_s:g} s" + (f" from {s.scan_offset_s:g} s" if s.scan_offset_s else "")
                        for s in sc.sensors)
    return f"{sc.n_scans} scans from {len(sc.sensors)} sensors ({periods})"


def plot_scenario(dataset: Dataset, out: str | Path, dpi: int = 120) -> Path:
    """Write a PNG with the whole coverage (left) and a zoom on the targets (right).

    Lines are the true tracks (a circle marks each start); dashed outlines
    are each sensor's coverage (range circles, or a sector) and a triangle
    its position. With one sensor, grey dots are clutter of every scan and
    coloured dots each target's contacts (in the colour of its track); with
    several, dots take their sensor's colour (faint: clutter; solid: target
    contacts) and tracks are black; black crosses (x, +, x, ... by sensor) mark a
    true position hidden from that sensor by a longer ship (occlusion,
    `nnda.data.occlusion`). Axes in km, x east, y north. The file
    appears whole or not at all (`nnda.files.atomic_output`; a full or
    read-only disk is an OutputError).
    """
    det, truth, sc = dataset.detections, dataset.truth, dataset.scenario
    fig, axes = plt.subplots(1, 2, figsize=(14, 7), constrained_layout=True)
    colours = plt.get_cmap("tab10")
    several = len(sc.sensors) > 1
    sensor_colour = [colours(j % 10) if several else "k" for j in range(len(sc.sensors))]
    for ax in axes:
        if several:
            for j, sensor in enumerate(sc.sensors):
                mine = det.sensor == j
                c = sensor_colour[j]
                ax.scatter(det.x[mine & det.is_clutter] * KM, det.y[mine & det.is_clutter] * KM, s=1, color=c,
                           alpha=0.25, lw=0, rasterized=True)
                ax.scatter(det.x[mine & ~det.is_clutter] * KM, det.y[mine & ~det.is_clutter] * KM, s=6, color=c,
                           lw=0, label=f"{sensor.name} ({int((mine & ~det.is_clutter).sum())} target contacts)")
        else:
            clutter = det.is_clutter
            ax.scatter(det.x[clutter] * KM, det.y[clutter] * KM, s=1, c="0.7", lw=0, label="clutter",
                       rasterized=True)
        for tid, target in enumerate(sc.targets):
            c = "k" if several else colours(tid % 10)
            mine = det.target_id == tid
            if not several:
                ax.scatter(det.x[mine] * KM, det.y[mine] * KM, s=6, color=c, lw=0)
            rows = truth.target_id == tid
            ax.plot(truth.x[rows] * KM, truth.y[rows] * KM, color=c, lw=1.2,
                    label=f"{target.name} ({mine.sum()} contacts)")
            if rows.any():
                first = np.flatnonzero(rows)[0]
                ax.plot(truth.x[first] * KM, truth.y[first] * KM, "o", mfc="none", color=c)
                if several:
                    ax.annotate(target.name, (truth.x[first] * KM, truth.y[first] * KM), fontsize=8,
                                xytext=(4, 4), textcoords="offset points")
        for j, (where, c) in enumerate(zip(hidden_from(dataset), sensor_colour)):
            if where.any():
                ax.plot(truth.x[where] * KM, truth.y[where] * KM, "x+"[j % 2], color="k", ms=5, mew=1.0, zorder=5,
                        label=f"hidden from {sc.sensors[j].name} by a longer ship ({int(where.sum())} scans)")
        for sensor, c in zip(sc.sensors, sensor_colour):
            for patch in coverage_patches(sensor, c):
                ax.add_patch(patch)
            ax.plot(sensor.x_m * KM, sensor.y_m * KM, "^", color=c, ms=8)
        ax.set_aspect("equal")
        ax.set_xlabel("x east (km)")
        ax.set_ylabel("y north (km)")
        ax.grid(alpha=0.3)
    x, y = np.concatenate([_outline(s) for s in sc.sensors], axis=1)
    margin = 0.05 * max(s.max_range_m for s in sc.sensors)
    whole = (((x.min() - margin) * KM, (x.max() + margin) * KM), ((y.min() - margin) * KM, (y.max() + margin) * KM))
    pad = 2.0  # km
    # the zoom: the targets' robust extent (`robust_range`), so one wild true position does not shrink it to a dot
    zoom = (robust_range(truth.x * KM, pad), robust_range(truth.y * KM, pad))
    if zoom[0] is None or zoom[1] is None:
        zoom = whole
    # points left outside a panel, drawn at its edge: the coverage panel's contacts and true positions, the zoom's
    # true positions (it leaves the far clutter out by design)
    everything = (np.concatenate([det.x, truth.x]) * KM, np.concatenate([det.y, truth.y]) * KM)
    for ax, box, (px, py), title in ((axes[0], whole, everything, "sensor coverage" if several else "radar coverage"),
                                     (axes[1], zoom, (truth.x * KM, truth.y * KM), "targets (zoom)")):
        ax.set(xlim=box[0], ylim=box[1], title=title)
        n_off = int(outside(px, py, box).sum())
        if n_off:
            edge_arrows(ax, box, px, py)
            what = "contact(s) or true position(s)" if ax is axes[0] else "true position(s)"
            ax.set_title(f"{title}: {n_off:,} {what} outside the view (drawn at the edge)")
    axes[1].legend(loc="best", fontsize=8, markerscale=4)
    n_clutter = int(det.is_clutter.sum())
    fig.suptitle(f"{sc.name}: {_timing(dataset)}, {n_clutter} clutter points ({n_clutter / sc.n_scans:.0f}/scan), "
                 f"seed {dataset.seed}, run {dataset.run}")
    try:
        with atomic_output(out, overwrite=True, directory=False) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png", metadata={"Software": None})
    finally:
        plt.close(fig)
    return Path(out)
