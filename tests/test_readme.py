"""The README's examples work as written."""

from __future__ import annotations

import re
from pathlib import Path

from nnda.data.generator import generate
from nnda.data.scenario import load_scenario

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_scenario_config_is_valid(tmp_path):
    block = re.search(r"```toml\n(.*?)```", README.read_text(), re.S).group(1)
    (tmp_path / "my.toml").write_text(block)
    sc = load_scenario(tmp_path / "my.toml")
    assert sc.n_scans == 60 and [s.kind for s in sc.targets[0].segments] == ["cv", "turn", "mixed"]
    assert generate(sc).truth.scan.size == 60
