"""The pages of a report directory: report.md, report.html and the PNG figures under figures/.

    write_pages(out, "Re-entry study", [section], figures)   # out/report.md, out/report.html, out/figures/*.png

The page builders (`nnda.reports.study_report`) load plotly, so they are imported only when a page is written.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

from nnda.files import atomic_file

REPORT_MD = "report.md"
REPORT_HTML = "report.html"
FIGURES = "figures"


def write_pages(out: Path, title: str, sections: Sequence, figures: Iterable = ()) -> None:
    """Write ``out``/report.md and report.html of ``sections`` (`Section`s) under ``title``, and each `Figure`
    of ``figures`` as ``out``/figures/<name>, every file atomically."""
    from nnda.reports.study_report import html_page, markdown_page

    for figure in figures:
        with atomic_file(out / FIGURES / figure.name) as tmp:
            tmp.write_bytes(figure.png)
    with atomic_file(out / REPORT_MD) as tmp:
        tmp.write_text(markdown_page(title, sections))
    with atomic_file(out / REPORT_HTML) as tmp:
        tmp.write_text(html_page(title, sections))
