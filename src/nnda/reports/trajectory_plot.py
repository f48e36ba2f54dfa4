"""Interactive trajectory plot of a study report (plotly, embedded offline).

One figure per scenario (run 0): each target's true trajectory and every
confirmed track of each tracker. A tracker is one legend entry (click to
hide or show it); hovering a track point shows the tracker, the track id,
its status at that scan, the scan and the time. The page carries plotly.js
inline once (`plotly_js`), so the report needs no network. The initial
view is the targets' area; tracks coasting out of it are a zoom-out away.
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from plotly.offline import get_plotlyjs

KM = 1e-3
#: margin (m) around the true trajectories in track plots; coasting tracks may run further out
VIEW_MARGIN_M = 3_000.0
#: the robust extent of a plot's points (`robust_range`): the share (%) left out at each end before widening
TRIM_PERCENT = 0.5
#: points beyond the trimmed range by at most this share of its span still set the extent; further ones are outliers
REACH = 0.5

Box = tuple[tuple[float, float], tuple[float, float]]


def robust_range(v: np.ndarray, margin: float = 0.0) -> tuple[float, float] | None:
    """(low, high) of the finite values ``v``, robust to a few wild ones: the range between the TRIM_PERCENT-th and
    (100 - TRIM_PERCENT)-th percentiles (nearest ranks inside: a lone outlier among 100 points does not drag it),
    widened to the furthest values within REACH times its span (at least ``margin``) beyond it, then by ``margin``.
    Values further out (one bad position 3,900 km away among tracks 30 km across) set no limit. None without
    finite values."""
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    if not v.size:
        return None
    lo = float(np.percentile(v, TRIM_PERCENT, method="higher"))
    hi = float(np.percentile(v, 100.0 - TRIM_PERCENT, method="lower"))
    lo, hi = min(lo, hi), max(lo, hi)
    reach = max(REACH * (hi - lo), margin)
    near = v[(v >= lo - reach) & (v <= hi + reach)]
    return float(near.min()) - margin, float(near.max()) + margin


def robust_box(x: np.ndarray, y: np.ndarray, margin: float) -> Box | None:
    """(x range, y range) of the points (x, y), each `robust_range` with ``margin`` (their units); None without
    finite points."""
    xr, yr = robust_range(x, margin), robust_range(y, margin)
    return None if xr is None or yr is None else (xr, yr)


def padded(box: Box, share: float = 0.05) -> Box:
    """``box`` widened on every side by ``share`` of its larger span (a box of no span by 1e-3 of its units)."""
    (x0, x1), (y0, y1) = box
    pad = share * max(x1 - x0, y1 - y0) or 1e-3
    return (x0 - pad, x1 + pad), (y0 - pad, y1 + pad)


def squared(box: Box) -> Box:
    """``box`` widened about its centre to a square of its larger span (for an equal-aspect plot)."""
    (x0, x1), (y0, y1) = box
    half = 0.5 * max(x1 - x0, y1 - y0)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    return (cx - half, cx + half), (cy - half, cy + half)


def outside(x: np.ndarray, y: np.ndarray, box: Box) -> np.ndarray:
    """Which finite points (x, y) lie outside ``box`` (x range, y range), (N,) bool."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    (x0, x1), (y0, y1) = box
    return np.isfinite(x) & np.isfinite(y) & ((x < x0) | (x > x1) | (y < y0) | (y > y1))


def edge_arrows(ax, box: Box, x: np.ndarray, y: np.ndarray) -> None:
    """Draw the finite points (x, y) outside ``box`` on the matplotlib axes ``ax``, each at the nearest point of
    the box's edge as a red arrow head pointing its way (legend: how many)."""
    off = outside(x, y, box)
    if not off.any():
        return
    x, y = np.asarray(x, float)[off], np.asarray(y, float)[off]
    (x0, x1), (y0, y1) = box
    cx, cy = np.clip(x, x0, x1), np.clip(y, y0, y1)
    dx, dy = x - cx, y - cy
    across = np.abs(dx) >= np.abs(dy)
    label = f"outside the view ({x.size:,}), at the edge"
    for marker, sel in ((">", across & (dx > 0)), ("<", across & (dx < 0)), ("^", ~across & (dy > 0)),
                        ("v", ~across & (dy < 0))):
        if sel.any():
            ax.scatter(cx[sel], cy[sel], marker=marker, s=40, c="tab:red", zorder=6, clip_on=False, label=label)
            label = None


def outside_note(counts: dict[str, int], how: str = "drawn at the edge") -> str:
    """The title's note on the points outside the view, e.g. ", 1 truth point(s) outside the view (drawn at the
    edge)"; empty when there are none. ``counts`` maps what (contact(s), truth point(s), ...) to how many;
    ``how`` says where they are."""
    parts = [f"{n:,} {what}" for what, n in counts.items() if n]
    return f", {' and '.join(parts)} outside the view ({how})" if parts else ""


def view_box(x: np.ndarray, y: np.ndarray) -> Box:
    """(x range, y range) in km: the true trajectories' robust extent (`robust_box`) plus VIEW_MARGIN_M, so one
    wild truth point does not shrink the picture."""
    box = robust_box(np.asarray(x, float) * KM, np.asarray(y, float) * KM, VIEW_MARGIN_M * KM)
    return ((-30.0, 30.0), (-30.0, 30.0)) if box is None else box


#: plotly's default qualitative colours, so that trackers keep one colour through the report
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")


def _gapped(rows: dict[str, np.ndarray], sel: np.ndarray, fields: tuple[str, ...]) -> dict[str, list]:
    """Columns of the selected rows, one track after another, with a None row between tracks (a line break)."""
    out: dict[str, list] = {f: [] for f in fields}
    ids = rows["id"][sel]
    for tid in np.unique(ids):
        pick = np.flatnonzero(sel)[ids == tid]
        for f in fields:
            out[f] += rows[f][pick].tolist() + [None]
    return out


def trajectory_figure(scenario: str, rows: dict[str, np.ndarray], trackers: list[str]) -> go.Figure:
    """The figure of one scenario from its ``trajectories.parquet`` rows (columns as arrays)."""
    fig = go.Figure()
    truth = rows["source"] == "truth"
    for tid in np.unique(rows["id"][truth]):
        sel = truth & (rows["id"] == tid)
        name = str(rows["name"][sel][0])
        fig.add_trace(go.Scatter(
            x=rows["x"][sel] * KM, y=rows["y"][sel] * KM, mode="lines", name=f"truth {name}",
            legendgroup="truth", line={"color": "rgba(90,90,90,0.45)", "width": 5},
            customdata=np.column_stack([rows["scan"][sel], rows["time"][sel]]),
            hovertemplate=f"<b>target {name}</b><br>scan %{{customdata[0]}}, t = %{{customdata[1]:.0f}} s"
                          "<br>x %{x:.2f} km, y %{y:.2f} km<extra></extra>",
        ))
    for i, tracker in enumerate(trackers):
        g = _gapped(rows, rows["source"] == tracker, ("x", "y", "id", "status", "scan", "time"))
        n_tracks = len(np.unique(rows["id"][rows["source"] == tracker]))
        custom = list(zip(g["id"], g["status"], g["scan"], g["time"]))
        fig.add_trace(go.Scatter(
            x=[None if v is None else v * KM for v in g["x"]], y=[None if v is None else v * KM for v in g["y"]],
            mode="lines+markers", name=f"{tracker} ({n_tracks} tracks)", legendgroup=tracker,
            line={"color": PALETTE[i % len(PALETTE)], "width": 1.5}, marker={"size": 4},
            customdata=custom, connectgaps=False,
            hovertemplate=f"<b>{tracker}</b><br>track %{{customdata[0]}} (%{{customdata[1]}})"
                          "<br>scan %{customdata[2]}, t = %{customdata[3]:.0f} s"
                          "<br>x %{x:.2f} km, y %{y:.2f} km<extra></extra>",
        ))
    xr, yr = view_box(rows["x"][truth], rows["y"][truth])
    track_rows = ~truth & np.isin(rows["source"], trackers)
    off = {what: int(outside(rows["x"][sel] * KM, rows["y"][sel] * KM, (xr, yr)).sum())
           for what, sel in (("truth point(s)", truth), ("track point(s)", track_rows))}
    fig.update_layout(
        title=f"{scenario}, run 0: true trajectories and confirmed tracks (hover a point; click the legend)"
              f"{outside_note(off, 'a zoom-out away')}",
        xaxis_title="x east (km)", yaxis_title="y north (km)", height=620, template="plotly_white",
        hovermode="closest", legend={"itemsizing": "constant"}, margin={"l": 60, "r": 20, "t": 60, "b": 50},
    )
    fig.update_xaxes(range=list(xr))
    fig.update_yaxes(range=list(yr), scaleanchor="x", scaleratio=1)
    return fig


def figure_div(fig: go.Figure, div_id: str) -> str:
    """The figure as an HTML <div> plus its script, without plotly.js itself."""
    return fig.to_html(full_html=False, include_plotlyjs=False, div_id=div_id,
                       config={"displaylogo": False, "responsive": True})


def plotly_js() -> str:
    """The plotly.js bundle shipped with the plotly package (no network)."""
    return get_plotlyjs()
