"""Tables of strings in three renderings (console, Markdown, HTML) and the one ``mean [low, high]`` formatter.

Every table nnda prints or writes is a `TextTable`: ``nnda train`` and
``nnda evaluate`` print it with rich and write its Markdown; the study
report writes its Markdown and HTML. Every cell that reads ``mean [low,
high]`` comes from `interval` (or `stat_cell`, for a ``mean_ci`` record of
``summary.json``)::

    interval(0.93, 0.91, 0.95, "{:.3f}")          # '0.930 [0.910, 0.950]'
    interval(0.0123, None, None, "{:.3g}", 1e3)   # '12.3' (no interval: one run)
    stat_cell({"mean": 99.6, "ci_low": 98.1, "ci_high": 100.0, "n": 3}, "{:.1f}")   # '99.6 [98.1, 100.0]'
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass

from rich.table import Table

#: an undefined or absent value
DASH = "—"
#: a column with a cell longer than this many characters is prose (set-up tables): it wraps, left-aligned
TEXT_CELL = 40
_TEXT = ' class="text"'


def _defined(v: float | None) -> bool:
    return v is not None and not math.isnan(v)


def interval(mean: float | None, low: float | None = None, high: float | None = None, fmt: str = "{:g}",
             scale: float = 1.0) -> str:
    """``mean [low, high]``, each number ``fmt.format(value * scale)``; the mean alone when the interval
    is undefined (None or NaN) or empty (low == high: every run gave the same value); DASH when the
    mean is undefined."""
    if not _defined(mean):
        return DASH
    text = fmt.format(mean * scale)
    if _defined(low) and _defined(high) and low != high:
        text += f" [{fmt.format(low * scale)}, {fmt.format(high * scale)}]"
    return text


def stat_cell(stat: dict | None, fmt: str, scale: float = 1.0) -> str:
    """`interval` of a ``mean_ci`` record (``mean``, ``ci_low``, ``ci_high``); DASH when absent."""
    if not stat:
        return DASH
    return interval(stat.get("mean"), stat.get("ci_low"), stat.get("ci_high"), fmt, scale)


@dataclass(frozen=True)
class TextTable:
    """A titled table of strings, with an optional note printed under it; the first column names the rows."""

    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    note: str = ""

    def rich(self) -> Table:
        """For the console: the first column left-aligned, the others right-aligned."""
        table = Table(title=self.title, caption=self.note or None, caption_justify="left")
        for i, name in enumerate(self.header):
            table.add_column(name, justify="left" if i == 0 else "right")
        for row in self.rows:
            table.add_row(*row)
        return table

    def markdown(self) -> str:
        """A ``###`` heading, the pipe table and the note."""
        lines = [f"### {self.title}", "", "| " + " | ".join(self.header) + " |",
                 "|" + "|".join(["---"] + ["---:"] * (len(self.header) - 1)) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in self.rows]
        if self.note:
            lines += ["", self.note]
        return "\n".join(lines) + "\n"

    def html(self, table_id: str = "") -> str:
        """An HTML <table> with the title as caption and the note below; prose columns (a cell over
        TEXT_CELL characters) get class "text" (they wrap, left-aligned)."""
        ident = f' id="{html.escape(table_id)}"' if table_id else ""
        head = "".join(f"<th>{html.escape(h)}</th>" for h in self.header)
        prose = {j for row in self.rows for j, c in enumerate(row) if len(c) > TEXT_CELL}
        body = "".join("<tr>" + "".join(f"<td{_TEXT if j in prose else ''}>{html.escape(c)}</td>"
                                        for j, c in enumerate(row)) + "</tr>" for row in self.rows)
        note = f'<p class="note">{html.escape(self.note)}</p>' if self.note else ""
        return (f'<div class="table"><table{ident}><caption>{html.escape(self.title)}</caption><thead><tr>{head}'
                f"</tr></thead><tbody>{body}</tbody></table></div>{note}")
