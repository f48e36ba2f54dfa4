"""The README and every documentation page run as written (the conventions: tests/docs_examples.py).

Each page runs in an empty directory of its own, with the installed ``nnda`` first on PATH.
The dated records (docs/records/) are a lab notebook: shown, never run.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from tests.docs_examples import REFUSED, blocks, runnable

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", ROOT / "CONTRIBUTING.md",
         *sorted(p for p in DOCS.rglob("*.md") if "records" not in p.relative_to(DOCS).parts)]
PAGES = [p for p in PAGES if p.exists()]


def _id(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.mark.parametrize("page", PAGES, ids=_id)
def test_page_blocks_are_run_or_skipped_with_a_reason(page):
    for b in blocks(page.read_text(encoding="utf-8")):
        assert not (b.lang in REFUSED and b.marker is None), (
            f"{_id(page)} {b.where}: a {b.lang} block is neither run nor skipped: write it as a console block "
            "('$ ' before each command) or put '<!-- skip: why -->' on the line before it")
        if b.marker and b.marker[0] == "skip":
            assert b.marker[1], f"{_id(page)} {b.where}: a skipped block must say why"


@pytest.mark.parametrize("page", [p for p in PAGES if runnable(p)], ids=_id)
def test_page_examples_run(page, tmp_path, monkeypatch):
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "MPLBACKEND": "Agg", "PYTHONHASHSEED": "0"}
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__docs__"}
    for b in blocks(page.read_text(encoding="utf-8")):
        where = f"{_id(page)} {b.where}"
        if b.marker and b.marker[0] == "skip":
            continue
        if b.marker and b.marker[0] == "file":
            target = tmp_path / b.marker[1]
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(b.text, encoding="utf-8")
        elif b.lang == "console":
            for cmd in b.commands():
                done = subprocess.run(["bash", "-eo", "pipefail", "-c", cmd], cwd=tmp_path, env=env,
                                      capture_output=True, text=True, timeout=900)
                assert done.returncode == 0, (
                    f"{where}: `{cmd}` exited {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
        elif b.lang == "python":
            exec(compile(b.text, where, "exec", dont_inherit=True), namespace)


@pytest.mark.parametrize("page", [ROOT / "README.md", ROOT / "CONTRIBUTING.md", ROOT / "CHANGELOG.md"], ids=_id)
def test_links_outside_the_site_lead_somewhere(page):
    """The README, CONTRIBUTING and CHANGELOG are read on their own (mkdocs checks only docs/): every
    relative link names a file of the repository."""
    text = page.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" in target or target.startswith("mailto:"):
            continue
        assert (page.parent / target).exists(), f"{_id(page)} links to {target}, which does not exist"
