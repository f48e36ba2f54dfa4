"""The report's track-deletions table: the means of results.parquet's deletion columns, contact trackers only."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from nnda.data.presets import PRESETS
from nnda.reports.deletions_section import deletions
from nnda.reports.study_report import build_report
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.tracking.lifecycle import DELETION_REASONS


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("deletions")
    (root / "s4.json").write_text(json.dumps(PRESETS["S4"].model_copy(update={"duration_s": 40.0})
                                             .model_dump(mode="json")))
    (root / "study.toml").write_text('name = "deletions"\nseed = 3\nruns = 2\n[trackers.gnn]\nkind = "gnn"\n'
                                     '[trackers.gnn-score]\nkind = "gnn"\n'
                                     'params = { lifecycle = { confirmation = "score" } }\n'
                                     '[trackers.ekphd]\nkind = "ekphd"\n[[scenarios]]\nconfig = "s4.json"\n')
    compare(load_study(root / "study.toml"), root / "out", workers=1)
    return root / "out"


def test_the_table_holds_the_mean_deletions_per_run(study):
    found = deletions(study)
    assert list(found) == ["gnn", "gnn-score"]  # the PHD filter has no life cycle
    t = pq.read_table(study / "results.parquet").to_pydict()
    for label, (rule, per) in found.items():
        rows = [i for i, name in enumerate(t["tracker"]) if name == label]
        assert rule == ("adaptive" if label == "gnn" else "score")  # gnn: the default rule
        for r in DELETION_REASONS:
            assert per[r] == pytest.approx(np.mean([t[f"deleted_{r}"][i] for i in rows]))
    md = build_report(study)[0]
    section = md[md.index("## Track deletions"):]
    section = section[:section.index("\n## ", 5)]
    assert "| gnn | adaptive score |" in section and "| gnn-score | track score |" in section and "ekphd" not in section
