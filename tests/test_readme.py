"""The README's examples work as written (tests/test_docs.py runs its commands; this checks the scenario)."""

from __future__ import annotations

import re
from pathlib import Path

from nnda.data.generator import generate
from nnda.data.scenario import load_scenario

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_scenario_config_is_valid(tmp_path):
    """The tour's scenario file (the block after `<!-- file: my.toml -->`) is the scenario it describes."""
    block = re.search(r"<!-- file: my\.toml -->\n```toml\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert block, "README.md has no `<!-- file: my.toml -->` toml block"
    (tmp_path / "my.toml").write_text(block.group(1))
    sc = load_scenario(tmp_path / "my.toml")
    assert sc.n_scans == 60 and [s.kind for s in sc.targets[0].segments] == ["cv", "turn", "mixed"]
    assert generate(sc).truth.scan.size == 60
