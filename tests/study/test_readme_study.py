"""The README's study example is a valid study."""

from __future__ import annotations

import re
from pathlib import Path

from nnda.study.config import load_study

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_study_example_loads(tmp_path):
    blocks = re.findall(r"```toml\n(.*?)```", README.read_text(), re.S)
    study_block = next(b for b in blocks if "[trackers." in b)
    (tmp_path / "study.toml").write_text(study_block)
    study = load_study(tmp_path / "study.toml")
    assert list(study.trackers) == ["nn-lm", "mht", "gnn"] and study.runs == 20
    assert study.models["lm"] == tmp_path / "models/lm" and study.trackers["nn-lm"].model == "lm"
