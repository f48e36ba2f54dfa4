"""The page model of every report: `Section`s of Markdown and HTML, PNG `Figure`s, and the pages they make.

    sec = Section("reentry", "Ballistic re-entry filters", [], [])
    sec.text("A paragraph with **bold** and `code`.")       # Markdown and its HTML
    sec.table(text_table)                                   # a nnda.reports.text_table.TextTable
    fig = Figure("rmse.png", "RMSE per step", draw_rmse, (results,))   # draw_rmse(results) -> PNG bytes
    sec.figure(fig)                                         # drawn when the page is written
    write_pages(out, "Re-entry study", [sec], [fig])        # out/report.md, out/report.html, out/figures/*.png

A report section is a function of a study's records that fills a `Section`;
this module knows no study. The HTML page is self-contained: figures are
embedded as base64 and any script (plotly.js for interactive figures) is
inlined, so it opens without network or sibling files.
"""

from __future__ import annotations

import base64
import functools
import html
import multiprocessing
import re
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from nnda.files import atomic_file
from nnda.reports.text_table import TextTable
from nnda.study.timing import join_timing

REPORT_MD = "report.md"
REPORT_HTML = "report.html"
FIGURES = "figures"


@dataclass(frozen=True)
class StudyFiles:
    """What a study directory's report sections read: the directory (for its checked tables), ``study.json``,
    and the checked ``summary.json`` and ``timing.json``."""

    out: Path
    manifest: dict
    summary: dict
    timing: dict

    def results(self, kind: str) -> dict:
        """A kind's results document: its ``summary.json`` entry with its wall-clock entries put back."""
        return join_timing(self.summary[kind], self.timing.get(kind, {}))


@dataclass(frozen=True)
class Figure:
    """A PNG figure: file name under figures/, caption, and how to draw it: ``draw(*args)`` returns the PNG's
    bytes (a module-level function of plain data, so a worker process can draw it). Nothing is drawn until the
    page is written (`render`)."""

    name: str
    caption: str
    draw: Callable[..., bytes]
    args: tuple = ()

    @functools.cached_property
    def png(self) -> bytes:
        """The figure's PNG bytes (drawn on first use, or by `render`)."""
        return self.draw(*self.args)


#: below this many figures, drawing them in this process is quicker than starting workers
PARALLEL_FIGURES = 6


def _drawn(figure: Figure) -> bytes:
    return figure.draw(*figure.args)


def render(figures: Sequence[Figure], workers: int = 2) -> dict[str, bytes]:
    """Draw every figure not drawn yet, on ``workers`` processes when there are `PARALLEL_FIGURES` or more (the
    same bytes either way); every figure's PNG by name."""
    names = [f.name for f in figures]
    if len(set(names)) != len(names):
        raise ValueError(f"figure names repeat: {sorted({n for n in names if names.count(n) > 1})}")
    todo = [f for f in figures if "png" not in f.__dict__]
    if workers >= 2 and len(todo) >= PARALLEL_FIGURES:
        # spawn: a worker starts clean (no copy of this process's threads or open figures)
        with ProcessPoolExecutor(min(workers, len(todo)), mp_context=multiprocessing.get_context("spawn")) as pool:
            for f, png in zip(todo, pool.map(_drawn, todo), strict=True):
                f.__dict__["png"] = png  # what `Figure.png` would draw
    return {f.name: f.png for f in figures}


@dataclass
class Section:
    """One report section in both renderings."""

    ident: str
    title: str
    md: list[str]
    html: list[str]

    def text(self, paragraph: str) -> None:
        self.md += [paragraph, ""]
        self.html.append(_md_html(paragraph))

    def table(self, table: TextTable, ident: str = "") -> None:
        self.md.append(table.markdown())
        self.html.append(table.html(ident))

    def figure(self, fig: Figure) -> None:
        """The figure in both renderings: a file link in Markdown, the image inlined in HTML once drawn."""
        self.md += [f"![{fig.caption}]({FIGURES}/{fig.name})", ""]
        self.html.append(f'<figure><img alt="{html.escape(fig.caption)}" src="data:image/png;base64,'
                         f'{_slot(fig.name)}"><figcaption>{html.escape(fig.caption)}</figcaption></figure>')


def _slot(name: str) -> str:
    """Where a figure's base64 goes in a section's HTML until it is drawn (no HTML or base64 text has NUL)."""
    return f"\0figure:{name}\0"


_SLOT = re.compile("\0figure:([^\0]*)\0")


def _inline(text: str) -> str:
    """Escape, then render **bold**, `code` and [links](relative/path) of our own generated Markdown."""
    text = html.escape(text)
    text = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", text)
    text = re.sub(r"\[([^\]]+)\]\(([^)\s]+)\)", r'<a href="\2">\1</a>', text)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", text)


def _md_html(text: str) -> str:
    """HTML of the small Markdown subset the report writes: paragraphs, '* ' bullet lists, bold, code."""
    out = []
    for block in text.strip().split("\n\n"):
        lines = block.splitlines()
        if all(line.startswith("* ") for line in lines):
            items = "".join(f"<li>{_inline(line[2:])}</li>" for line in lines)
            out.append(f"<ul>{items}</ul>")
        else:
            out.append(f"<p>{_inline(' '.join(lines))}</p>")
    return "".join(out)


def markdown_page(title: str, sections: Sequence[Section]) -> str:
    """A whole Markdown page: the title and each section under its heading."""
    md = "\n".join([f"# {title}", ""] + [line for s in sections for line in [f"## {s.title}", "", *s.md]])
    return md.rstrip() + "\n"


_CSS = """
body { font: 16px/1.5 system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto; max-width: 1300px;
       padding: 0 2em 3em; color: #222; }
h1 { font-size: 1.6em; margin: .6em 0 .2em; } h2 { font-size: 1.3em; margin: 1.6em 0 .4em; }
h2 { border-bottom: 1px solid #ddd; padding-bottom: .15em; }
nav.toc { font-size: .85em; line-height: 1.8; padding: .2em 0 .4em; border-bottom: 1px solid #ddd; }
nav.toc strong { margin-right: .6em; } nav.toc a { margin-right: 1em; white-space: nowrap; }
a { color: #1f5fa8; text-decoration: none; } a:hover { text-decoration: underline; }
div.table { overflow: auto; max-height: 85vh; margin: 1em 0 .3em; }
table { border-collapse: separate; border-spacing: 0; font-size: .85em; }
caption { text-align: left; font-weight: 600; padding: .3em 0; position: sticky; left: 0; }
th, td { border-right: 1px solid #ccc; border-bottom: 1px solid #ccc; padding: .2em .5em; text-align: right;
         white-space: nowrap; background: #fff; }
tr > :first-child { border-left: 1px solid #ccc; } thead th { border-top: 1px solid #ccc; }
th:first-child, td:first-child { text-align: left; white-space: pre; position: sticky; left: 0; z-index: 1; }
thead th { background: #f3f3f3; position: sticky; top: 0; z-index: 2; }
thead th:first-child { z-index: 3; }
td.text { text-align: left; white-space: normal; min-width: 24em; max-width: 48em; }
p.note { font-size: .85em; color: #555; margin-top: 0; max-width: 60em; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; }
figcaption { font-size: .85em; color: #555; max-width: 60em; }
code { background: #f3f3f3; padding: 0 .2em; }
"""


def html_page(title: str, sections: Sequence[Section], script: str = "", pngs: Mapping[str, bytes] | None = None
              ) -> str:
    """A whole HTML page: the title, a table of contents (links to the section ids) and the sections with their
    figures' ``pngs`` (by name, `render`) inlined; ``script`` (JavaScript, e.g. plotly.js for interactive
    figures) goes inline into the head."""
    toc = " ".join(f'<a href="#{s.ident}">{html.escape(s.title)}</a>' for s in sections)
    body = "".join(f'<section id="{s.ident}"><h2>{html.escape(s.title)}</h2>{"".join(s.html)}</section>'
                   for s in sections)
    body = _SLOT.sub(lambda m: base64.b64encode((pngs or {})[m.group(1)]).decode(), body)
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<style>{_CSS}</style>{f'<script>{script}</script>' if script else ''}</head>"
            f'<body><h1>{html.escape(title)}</h1><nav class="toc" aria-label="Contents"><strong>Contents</strong>'
            f"{toc}</nav>{body}</body></html>\n")


def write_pages(out: Path, title: str, sections: Sequence[Section], figures: Sequence[Figure] = (),
                script: str = "") -> Path:
    """Draw ``figures`` (`render`), write each as ``out``/figures/<name>, then ``out``/report.md and report.html
    of ``sections`` under ``title`` (``script`` inlined in the HTML), every file atomically; returns the HTML
    page's path."""
    pngs = render(figures)
    for name, png in pngs.items():
        with atomic_file(out / FIGURES / name) as tmp:
            tmp.write_bytes(png)
    with atomic_file(out / REPORT_MD) as tmp:
        tmp.write_text(markdown_page(title, sections))
    with atomic_file(out / REPORT_HTML) as tmp:
        tmp.write_text(html_page(title, sections, script, pngs))
    return out / REPORT_HTML
