"""Position plots take their extent from the data's robust range: one wild position does not shrink the picture to a
dot, and the points left outside the view are counted and drawn at its edge."""

from __future__ import annotations

import io
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.reports import scenario_plot, track_plot
from nnda.reports.trajectory_plot import outside, robust_range, trajectory_figure, view_box
from nnda.study.track import run_tracker

FAR_M = 3.9e6  # a bad AIS-like position 3,900 km away
CLOSE = plt.close  # the plots close their figures: the tests look at them first


@pytest.fixture(scope="module")
def run():
    """A short scene (two targets, light clutter) tracked by GNN: its dataset and track table."""
    targets = [Target(name=f"T{k}", x_m=-3_000.0, y_m=8_000.0 + 3_000.0 * k, heading_deg=90.0, speed_m_s=150.0,
                      segments=[Segment(duration_s=40.0)]) for k in range(2)]
    dataset = generate(Scenario(name="wild", duration_s=40.0, targets=targets, clutter=Clutter(count=20), seed=4))
    return dataset, run_tracker(dataset, "gnn").table


def _with_outlier(dataset, what: str):
    """``dataset`` with one contact (``what`` = "contact") or one true position ("truth") moved 3,900 km east."""
    if what == "contact":
        x = dataset.detections.x.copy()
        x[len(x) // 2] += FAR_M
        return replace(dataset, detections=replace(dataset.detections, x=x))
    x = dataset.truth.x.copy()
    x[len(x) // 2] += FAR_M
    return replace(dataset, truth=replace(dataset.truth, x=x))


def _limits(monkeypatch, draw) -> list[tuple[tuple[float, float], tuple[float, float], str]]:
    """The final (xlim, ylim, title) of every axes ``draw()`` makes (figures are captured before closing)."""
    seen = []

    def keep(fig):
        seen.extend((ax.get_xlim(), ax.get_ylim(), ax.get_title()) for ax in fig.axes)
        CLOSE(fig)

    monkeypatch.setattr(plt, "close", keep)
    draw()
    return seen


def _span(lim):
    return lim[1] - lim[0]


@pytest.mark.parametrize("what", ["contact", "truth"])
def test_tracks_png_keeps_its_extent_and_reports_the_outlier(run, what, monkeypatch):
    dataset, table = run
    (xlim0, ylim0, _), = _limits(monkeypatch, lambda: track_plot.track_png(dataset, table, "gnn"))
    (xlim, ylim, title), = _limits(monkeypatch, lambda: track_plot.track_png(_with_outlier(dataset, what), table,
                                                                             "gnn"))
    assert xlim[1] < 100.0 and _span(xlim) < 2 * _span(xlim0) and _span(ylim) < 2 * _span(ylim0)  # km
    kind = "contact(s)" if what == "contact" else "truth point(s)"
    assert f"1 {kind} outside the view (drawn at the edge)" in title
    assert "outside the view" not in _limits(monkeypatch, lambda: track_plot.track_png(dataset, table, "gnn"))[0][2]


def test_tracks_png_draws_the_outlier_as_an_arrow_at_the_edge(run, monkeypatch):
    dataset, table = run
    arrows = []

    def keep(fig):
        for ax in fig.axes:
            for coll in ax.collections:
                if coll.get_label().startswith("outside the view"):
                    arrows.append((np.asarray(coll.get_offsets()).copy(), ax.get_xlim()))
        CLOSE(fig)

    monkeypatch.setattr(plt, "close", keep)
    track_plot.track_png(_with_outlier(dataset, "contact"), table, "gnn")
    (points, xlim), = arrows
    assert points.shape == (1, 2) and xlim[0] <= points[0, 0] <= xlim[1] and points[0, 0] > 0.9 * xlim[1]


def test_tracks_html_keeps_its_extent_and_reports_the_outlier(run):
    dataset, table = run
    fig = track_plot.track_figure(_with_outlier(dataset, "contact"), table, "gnn")
    assert fig.layout.xaxis.range[1] < 100.0
    assert "1 contact(s) outside the view (a zoom-out away)" in fig.layout.title.text


def test_scenario_plot_zoom_keeps_its_extent(run, monkeypatch, tmp_path):
    dataset, _ = run
    wild = _with_outlier(dataset, "truth")
    (cover0, zoom0), (cover, zoom) = (
        _limits(monkeypatch, lambda d=d: scenario_plot.plot_scenario(d, tmp_path / "s.png", dpi=40))
        for d in (dataset, wild))
    assert zoom[0] == zoom0[0] and zoom[1] == zoom0[1]  # the planted point moves nothing
    assert zoom[2] == "targets (zoom): 1 true position(s) outside the view (drawn at the edge)"
    assert cover[0] == cover0[0] and cover[2].endswith(": 1 contact(s) or true position(s) outside the view (drawn at "
                                                        "the edge)")
    assert "outside" not in zoom0[2] and "outside" not in cover0[2]


def test_trajectory_figure_keeps_its_view(run):
    dataset, table = run
    t = dataset.truth
    x = t.x.copy()
    x[5] += FAR_M
    rows = {"source": np.array(["truth"] * x.size, dtype=object), "id": t.target_id, "name": np.array(["T"] * x.size),
            "x": x, "y": t.y, "scan": t.scan, "time": t.scan * 2.0, "status": np.array(["confirmed"] * x.size)}
    fig = trajectory_figure("wild", rows, [])
    assert fig.layout.xaxis.range[1] < 100.0
    assert "1 truth point(s) outside the view (a zoom-out away)" in fig.layout.title.text
    assert view_box(t.x, t.y) == view_box(np.append(t.x, FAR_M), np.append(t.y, 0.0))


def test_robust_range_keeps_every_near_point_and_drops_a_far_one():
    v = np.linspace(0.0, 30.0, 100)
    assert robust_range(v) == (0.0, 30.0)  # the extremes are near: kept, though the trim leaves them out first
    assert robust_range(np.append(v, 3_900.0)) == (0.0, 30.0)
    assert robust_range(np.append(v, 3_900.0), margin=2.0) == (-2.0, 32.0)
    assert robust_range(np.array([np.nan, np.inf])) is None
    assert outside(np.array([1.0, 50.0, np.nan]), np.zeros(3), ((0.0, 30.0), (-1.0, 1.0))).tolist() == [False, True,
                                                                                                          False]


def test_png_bytes_are_stable(run):
    dataset, table = run
    wild = _with_outlier(dataset, "contact")
    assert track_plot.track_png(wild, table, "gnn") == track_plot.track_png(wild, table, "gnn")
    assert io.BytesIO(track_plot.track_png(wild, table, "gnn")).read(8) == b"\x89PNG\r\n\x1a\n"
