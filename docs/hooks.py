"""Build-time hooks of the documentation site (mkdocs.yml ``hooks``).

The command-line reference (reference/cli.md) is generated from nnda's Typer app by Typer's own
Markdown generator (``typer nnda.app.cli utils docs``) each time the site is built, so it cannot drift
from the commands: the page's ``<!-- commands -->`` line is replaced by it, headings one level down.
"""

from __future__ import annotations

import re
import subprocess
import sys

MARKER = "<!-- commands -->"


def _commands() -> str:
    done = subprocess.run([sys.executable, "-m", "typer", "nnda.app.cli", "utils", "docs", "--name", "nnda"],
                          capture_output=True, text=True, check=True)
    return re.sub(r"^(#+) ", r"#\1 ", done.stdout, flags=re.M)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri == "reference/cli.md":
        if MARKER not in markdown:
            raise ValueError(f"reference/cli.md has lost its {MARKER} line")
        return markdown.replace(MARKER, _commands())
    return markdown
