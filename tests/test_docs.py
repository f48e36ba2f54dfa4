"""The README and every documentation page run as written (the conventions: tests/docs_examples.py).

Each page runs in an empty directory of its own, with the installed ``nnda`` first on PATH. A plain
``nnda ARGS`` command (no shell syntax) runs in this process through ``nnda.app.cli.main``, the entry point
of the installed script (the same exit status; no new interpreter to start, and the kernels already compiled
serve it); any other command runs in bash. The installed script itself runs in tests/test_extras.py.
The dated records (docs/records/) are a lab notebook: shown, never run.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from tests.docs_examples import REFUSED, blocks, runnable

from nnda.app.cli import main

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


#: characters that make a command shell syntax (pipes, redirections, substitutions, lists, globs, quotes)
SHELL_SYNTAX = re.compile(r"[|&;<>$`()*?\[\]{}~'\"\\\n#]")


def nnda_args(cmd: str) -> list[str] | None:
    """The arguments of a plain ``nnda ARGS`` command (continued lines joined), or None for anything that needs
    the shell."""
    cmd = cmd.replace("\\\n", " ")
    if SHELL_SYNTAX.search(cmd):
        return None
    words = shlex.split(cmd)
    return words[1:] if words[:1] == ["nnda"] else None


def run_in_process(args: list[str], monkeypatch, capsys) -> tuple[int, str]:
    """``nnda ARGS`` through the installed script's entry point in this process: (exit status, its output)."""
    capsys.readouterr()
    with monkeypatch.context() as m:
        m.setattr(sys, "argv", ["nnda", *args])
        try:
            main()
            code = 0
        except SystemExit as done:
            code = done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    out = capsys.readouterr()
    return code, out.out[-3000:] + "\n" + out.err[-3000:]


@pytest.mark.parametrize("cmd, args", [("nnda track data/S1 --tracker mht --out tracks/S1 --quiet",
                                        ["track", "data/S1", "--tracker", "mht", "--out", "tracks/S1", "--quiet"]),
                                       ("nnda --version", ["--version"]),
                                       ("nnda generate --config bad.toml --out data/bad || echo \"exit $?\"", None),
                                       ("ls data/train08 data/train08/run-0000", None),
                                       ("nnda train --data data/train --starts 3 \\\n    --out models/ext",
                                        ["train", "--data", "data/train", "--starts", "3", "--out", "models/ext"]),
                                       ("ls data/*", None),
                                       ("nnda import-detections plots-eu.csv --delimiter ';' --out d", None)])
def test_only_plain_nnda_commands_run_in_process(cmd, args):
    assert nnda_args(cmd) == args


def test_a_refused_command_in_process_gives_its_exit_status(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code, output = run_in_process(["generate", "--preset", "S9", "--out", "d"], monkeypatch, capsys)
    assert code == 2 and "unknown preset 'S9'" in output


@pytest.mark.parametrize("page", [p for p in PAGES if runnable(p)], ids=_id)
def test_page_examples_run(page, tmp_path, monkeypatch, capsys):
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "MPLBACKEND": "Agg", "PYTHONHASHSEED": "0"}
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
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
                args = nnda_args(cmd)
                if args is not None:
                    code, output = run_in_process(args, monkeypatch, capsys)
                    assert code == 0, f"{where}: `{cmd}` exited {code}\n{output}"
                    continue
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
