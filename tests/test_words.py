"""Nothing a user or a maintainer reads names a document they cannot look up.

nnda cites its reference works by author and year ("Frencl (2014), Test 2"). The code, the CLI's text,
the shipped studies, the tests, the benchmarks, the README and the docs never name the project's
internal specifications or its issue tracker: no ``seed-00N``, no "issue N", no "spec §". The dated
records (docs/records/) are a lab notebook and are exempt, as is the changelog's table of renamed
values. A deprecated spelling kept for one version may appear on the lines that map it to its new
name, marked ``# deprecated spelling``.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INTERNAL = re.compile(r"seed-00\d|\bissues? \d|spec §|shared/spec", re.IGNORECASE)
TEXT = {".py", ".md", ".toml", ".json", ".txt", ".yml", ".yaml", ".cfg", ".html", ".csv"}


def _files():
    yield ROOT / "README.md"
    yield ROOT / "CONTRIBUTING.md"
    yield ROOT / "mkdocs.yml"
    for top in ("src", "docs", "tests", "benchmarks"):
        for path in sorted((ROOT / top).rglob("*")):
            rel = path.relative_to(ROOT)
            if (path.is_file() and path.suffix in TEXT and "records" not in rel.parts
                    and ".egg-info" not in str(rel) and path != Path(__file__).resolve()):
                yield path


def test_no_internal_references():
    found = []
    for path in _files():
        for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if INTERNAL.search(line) and "# deprecated spelling" not in line:
                found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:120]}")
    assert not found, "internal references (cite the work by author and year instead):\n" + "\n".join(found)
