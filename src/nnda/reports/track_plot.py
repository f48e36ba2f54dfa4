"""Tracks over contacts of one tracker on one dataset (``nnda track``): a PNG and an interactive HTML page.

Both show every contact (a grey dot; for very long files an evenly spaced
subset of at most `MAX_CONTACTS`, said in the title), the true trajectories
when the dataset has truth, and each ever-confirmed track as a line through
its confirmed reports. The view is the robust extent of all of them
(`trajectory_plot.robust_box`, widened by 5%): a few wild positions (a bad
fix thousands of km away) do not shrink the picture to a dot; the title
counts the points outside the view, and the PNG draws each at the nearest
edge as an arrow pointing its way. The HTML page carries plotly.js inline (opens
offline); hovering a track point shows its id, status, scan and time. Both
are byte-for-byte the same for the same inputs.
"""

from __future__ import annotations

import html
import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import plotly.graph_objects as go  # noqa: E402
import pyarrow as pa  # noqa: E402

from nnda.data.dataset import Dataset  # noqa: E402
from nnda.reports.trajectory_plot import (  # noqa: E402
    PALETTE,
    Box,
    edge_arrows,
    figure_div,
    outside,
    outside_note,
    padded,
    plotly_js,
    robust_box,
    squared,
)

KM = 1e-3
#: contacts drawn at most (an even stride through the file beyond this)
MAX_CONTACTS = 100_000


def _contacts(dataset: Dataset) -> tuple[np.ndarray, np.ndarray, str]:
    d = dataset.detections
    n = d.scan.size
    step = max(1, -(-n // MAX_CONTACTS))
    note = f" (every {step}th of {n:,} contacts)" if step > 1 else ""
    return d.x[::step], d.y[::step], note


def _confirmed_tracks(table: pa.Table) -> list[dict[str, np.ndarray]]:
    """Per track ever confirmed: the columns of its confirmed rows, in scan order."""
    cols = {c: table.column(c).to_numpy(zero_copy_only=False) for c in ("scan", "time", "track_id", "status", "x",
                                                                       "y")}
    keep = cols["status"] == "confirmed"
    out = []
    for tid in np.unique(cols["track_id"][keep]):
        sel = keep & (cols["track_id"] == tid)
        out.append({c: v[sel] for c, v in cols.items()})
    return out


def _truth(dataset: Dataset) -> list[tuple[str, np.ndarray, np.ndarray]]:
    t, names = dataset.truth, [tg.name for tg in dataset.scenario.targets]
    return [(names[i], t.x[t.target_id == i], t.y[t.target_id == i]) for i in np.unique(t.target_id)]


def _view(x: np.ndarray, y: np.ndarray, truth: list, tracks: list[dict[str, np.ndarray]]
          ) -> tuple[Box | None, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The view (x range, y range) in km of the contacts (x, y) m, the truth and the tracks: their robust extent
    together, padded by 5% and made square about its centre (None without finite points); and per kind the
    points (km) outside it."""
    groups = {"contact(s)": (x, y),
              "truth point(s)": (np.concatenate([t[1] for t in truth] or [np.empty(0)]),
                               np.concatenate([t[2] for t in truth] or [np.empty(0)])),
              "track point(s)": (np.concatenate([t["x"] for t in tracks] or [np.empty(0)]),
                               np.concatenate([t["y"] for t in tracks] or [np.empty(0)]))}
    groups = {k: (np.asarray(gx, float) * KM, np.asarray(gy, float) * KM) for k, (gx, gy) in groups.items()}
    box = robust_box(np.concatenate([g[0] for g in groups.values()]), np.concatenate([g[1] for g in groups.values()]),
                     0.0)
    if box is None:
        return None, {}
    box = squared(padded(box))
    return box, {k: (gx[off], gy[off]) for k, (gx, gy) in groups.items() if (off := outside(gx, gy, box)).any()}


def track_png(dataset: Dataset, table: pa.Table, tracker: str) -> bytes:
    """The PNG: contacts, truth and confirmed tracks in km (x east, y north), over their robust extent (`_view`)
    with the points outside it drawn at the edge."""
    fig, ax = plt.subplots(figsize=(8, 8))
    x, y, note = _contacts(dataset)
    ax.scatter(x * KM, y * KM, s=5, c="0.6", lw=0, label="contacts", rasterized=True)
    truth = _truth(dataset)
    for i, (name, tx, ty) in enumerate(truth):
        ax.plot(tx * KM, ty * KM, color="0.35", lw=3, alpha=0.4, label="truth" if i == 0 else None)
    tracks = _confirmed_tracks(table)
    for i, tr in enumerate(tracks):
        ax.plot(tr["x"] * KM, tr["y"] * KM, "-", marker=".", ms=3, lw=1, color=PALETTE[i % len(PALETTE)])
    box, off = _view(x, y, truth, tracks)
    if box is not None:
        ax.set_xlim(*box[0])
        ax.set_ylim(*box[1])
        if off:
            edge_arrows(ax, box, np.concatenate([g[0] for g in off.values()]),
                        np.concatenate([g[1] for g in off.values()]))
    off_note = outside_note({k: v[0].size for k, v in off.items()})
    o = dataset.geodetic_origin
    where = f"\norigin lat {o.lat_deg:.6f} deg, lon {o.lon_deg:.6f} deg, alt {o.alt_m:g} m (WGS 84)" if o else ""
    ax.set_title(f"{dataset.scenario.name}: {tracker}, {len(tracks)} confirmed track(s) over contacts{note}"
                 f"{off_note}{where}", fontsize=10, wrap=True)
    ax.set_xlabel("x east (km)")
    ax.set_ylabel("y north (km)")
    ax.set_aspect("equal", adjustable="box")  # the view is square (`_view`)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def track_figure(dataset: Dataset, table: pa.Table, tracker: str) -> go.Figure:
    """The interactive figure: one legend entry for the contacts, the truth, and each track."""
    fig = go.Figure()
    x, y, note = _contacts(dataset)
    fig.add_trace(go.Scattergl(x=x * KM, y=y * KM, mode="markers", name="contacts", hoverinfo="skip",
                               marker={"size": 3, "color": "rgba(150,150,150,0.5)"}))
    for name, tx, ty in _truth(dataset):
        fig.add_trace(go.Scatter(x=tx * KM, y=ty * KM, mode="lines", name=f"truth {name}", legendgroup="truth",
                                 line={"color": "rgba(90,90,90,0.45)", "width": 5}, hoverinfo="name"))
    tracks = _confirmed_tracks(table)
    box, off = _view(x, y, _truth(dataset), tracks)
    for i, tr in enumerate(tracks):
        fig.add_trace(go.Scatter(
            x=tr["x"] * KM, y=tr["y"] * KM, mode="lines+markers", name=f"track {tr['track_id'][0]}",
            line={"color": PALETTE[i % len(PALETTE)], "width": 1.5}, marker={"size": 4},
            customdata=np.column_stack([tr["track_id"], tr["scan"], tr["time"]]),
            hovertemplate="<b>track %{customdata[0]}</b> (confirmed)<br>scan %{customdata[1]}, "
                          "t = %{customdata[2]:.1f} s<br>x %{x:.2f} km, y %{y:.2f} km<extra></extra>"))
    off_note = outside_note({k: v[0].size for k, v in off.items()}, "a zoom-out away")
    fig.update_layout(
        title=f"{dataset.scenario.name}: {tracker}, {len(tracks)} confirmed track(s) over contacts{note}{off_note}",
        xaxis_title="x east (km)", yaxis_title="y north (km)", height=720, template="plotly_white",
        hovermode="closest", margin={"l": 60, "r": 20, "t": 60, "b": 50})
    fig.update_yaxes(scaleanchor="x", scaleratio=1)
    if box is not None:
        fig.update_xaxes(range=list(box[0]))
        fig.update_yaxes(range=list(box[1]))
    return fig


def track_html(dataset: Dataset, table: pa.Table, tracker: str) -> str:
    """A self-contained HTML page of `track_figure` (plotly.js inline)."""
    title = html.escape(f"nnda track: {tracker} on {dataset.scenario.name}")
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{title}</title>"
            f"<script>{plotly_js()}</script></head>\n<body>\n"
            f"{figure_div(track_figure(dataset, table, tracker), 'tracks')}\n</body></html>\n")
