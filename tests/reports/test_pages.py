"""The page model: figures drawn lazily, in worker processes or here with the same bytes, inlined in the HTML."""

from __future__ import annotations

import base64

import pytest

from nnda.reports.pages import PARALLEL_FIGURES, Figure, Section, html_page, markdown_page, render


def square(i: int) -> bytes:
    """A small PNG that differs with ``i``."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(1, 1))
    ax.bar([0], [i])
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def test_figures_drawn_on_workers_are_the_bytes_drawn_here():
    figures = [Figure(f"f{i}.png", f"figure {i}", square, (i,)) for i in range(PARALLEL_FIGURES)]
    pngs = render(figures, workers=2)
    assert pngs == {f"f{i}.png": square(i) for i in range(PARALLEL_FIGURES)}
    assert all(f.png == pngs[f.name] for f in figures)


def test_a_section_inlines_its_figure_once_drawn():
    fig = Figure("one.png", "one <bar>", square, (3,))
    sec = Section("s", "S", [], [])
    sec.figure(fig)
    assert "![one <bar>](figures/one.png)" in markdown_page("T", [sec])
    page = html_page("T", [sec], pngs=render([fig]))
    assert f'src="data:image/png;base64,{base64.b64encode(square(3)).decode()}"' in page
    assert 'alt="one &lt;bar&gt;"' in page and "\0" not in page
    with pytest.raises(ValueError, match="figure names repeat"):
        render([fig, Figure("one.png", "again", square, (4,))])
