"""The runnable examples of a Markdown page: its console commands, Python blocks and example files.

A page's fenced blocks run in page order in one empty working directory:

- a ``console`` block: each line starting with ``$ `` is a shell command (a trailing backslash
  continues it on the next line); the other lines are the output it shows, not checked;
- a ``python`` block: run in one namespace shared by the page's Python blocks;
- any block right after a ``<!-- file: NAME -->`` line: written to NAME (a study file, a CSV, ...);
- a block right after a ``<!-- skip: REASON -->`` line is shown, never run (set-up commands,
  a Dask cluster, runs that take minutes).

``bash``, ``sh`` and ``shell`` blocks are refused: a command must be either run or skipped with a
reason, so an example cannot drift from the code unnoticed.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from pathlib import Path

FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})\s*(?P<lang>[\w+-]*)")
MARKER = re.compile(r"^\s*<!--\s*(?P<what>file|skip):\s*(?P<arg>.*?)\s*-->\s*$")
REFUSED = {"bash", "sh", "shell", "zsh"}


@dataclass(frozen=True)
class Block:
    """One fenced block: its language, text (dedented), the page line of its fence, and its marker."""

    lang: str
    text: str
    line: int
    marker: tuple[str, str] | None = None

    @property
    def where(self) -> str:
        return f"line {self.line}"

    def commands(self) -> list[str]:
        """The ``$ `` commands of a console block, continuation lines joined."""
        out: list[str] = []
        pending: str | None = None
        for raw in self.text.splitlines():
            if pending is not None:
                pending += "\n" + raw
            elif raw.startswith("$ "):
                pending = raw[2:]
            else:
                continue
            if not pending.rstrip().endswith("\\"):
                out.append(pending)
                pending = None
        if pending is not None:
            raise ValueError(f"{self.where}: a command ends with a continuation backslash")
        return out


def blocks(text: str) -> list[Block]:
    """Every fenced block of a Markdown page, in order."""
    lines = text.splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, indent = m["fence"], len(m["indent"])
        body: list[str] = []
        j = i + 1
        while j < len(lines) and not re.match(rf"^\s*{re.escape(fence[0])}{{{len(fence)},}}\s*$", lines[j]):
            body.append(lines[j][indent:] if lines[j][:indent].strip() == "" else lines[j])
            j += 1
        if j == len(lines):
            raise ValueError(f"line {i + 1}: a fenced block is never closed")
        prev = lines[i - 1] if i > 0 else ""
        mk = MARKER.match(prev)
        found.append(Block(m["lang"].lower(), textwrap.dedent("\n".join(body)) + "\n", i + 1,
                           (mk["what"], mk["arg"]) if mk else None))
        i = j + 1
    return found


def runnable(path: Path) -> bool:
    """Whether a page has anything to run."""
    return any(b.marker is None and b.lang in {"console", "python"} or (b.marker or ("",))[0] == "file"
               for b in blocks(path.read_text(encoding="utf-8")))
