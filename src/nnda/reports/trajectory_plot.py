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


def view_box(x: np.ndarray, y: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    """(x range, y range) in km: the true trajectories' bounding box plus VIEW_MARGIN_M."""
    if x.size == 0:
        return (-30.0, 30.0), (-30.0, 30.0)
    m = VIEW_MARGIN_M
    return (((x.min() - m) * KM, (x.max() + m) * KM), ((y.min() - m) * KM, (y.max() + m) * KM))


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
    fig.update_layout(
        title=f"{scenario}, run 0: true trajectories and confirmed tracks (hover a point; click the legend)",
        xaxis_title="x east (km)", yaxis_title="y north (km)", height=620, template="plotly_white",
        hovermode="closest", legend={"itemsizing": "constant"}, margin={"l": 60, "r": 20, "t": 60, "b": 50},
    )
    xr, yr = view_box(rows["x"][truth], rows["y"][truth])
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
