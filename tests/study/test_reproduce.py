"""``nnda reproduce`` at a tiny size: every reference work's study runs, and the first table of its report is
right: each row's number is the study's own, each verdict is the one its interval gives, and a planted change of
a reference claim flips it."""

from __future__ import annotations

import dataclasses

import pytest
from typer.testing import CliRunner

from nnda.app import reproduce
from nnda.app.cli import app
from nnda.reports.claims import AGREES, HIGHER, HOLDS, LOWER, NOT_MEASURED, REVERSED, Claim
from nnda.reports.reproduction import CLAIMS, claims_table, write_reproduction
from nnda.reports.study_report import study_files
from nnda.reports.text_table import stat_cell

TINY = {"radar": {"runs": 2}, "harbour": {"runs": 2},
        "pedestrian": {"pedestrian": {"tests": ["test2", "test4"], "runs": 3, "test4_runs": 3, "stress_runs": 2,
                                      "beyond": False, "bootstrap": 100}},
        "reentry": {"reentry": {"runs": 4, "steps": 8}},
        "tbd": {"tbd": {"runs": 3, "scene": {"rows": 32, "cols": 32, "frames": 6}, "divergence_frames": 2,
                        "steady_frames": 2, "acquisition": 2, "chain": None,
                        "exit_reentry": {"runs": 1, "frames": 12, "exit_frames": 3, "reentry_frame": 8}}}}


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce") / "out"
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(reproduce.SIZES, "quick", TINY)
        # in this process: the kernels it compiled already serve every study (local workers: tests/study/test_runner.py)
        result = CliRunner().invoke(app, ["reproduce", "--out", str(out), "--quick", "--jobs", "1"])
    assert result.exit_code == 0, result.output + repr(result.exception)
    return out


def _rows(md: str) -> list[list[str]]:
    table = md.split("### The reference works' claims against nnda")[1].split("\n\n")[1]
    return [[c.strip() for c in line.strip("|").split("|")] for line in table.splitlines()[2:]]


def test_the_first_table_holds_every_claim_with_the_studys_numbers(reproduced):
    md = (reproduced / "report.md").read_text()
    assert md.index("### The reference works' claims against nnda") < md.index("## The studies")
    rows = _rows(md)
    assert len(rows) == len(CLAIMS) and [r[1] for r in rows] == [c.text for c in CLAIMS]
    studies = {name: study_files(reproduced / name) for name in reproduce.STUDIES}
    s1 = next(s for s in studies["radar"].summary["scenarios"] if s["name"] == "S1")
    hit = s1["trackers"]["mht"]["metrics"]["hit_rate"]
    row = rows[[c.text for c in CLAIMS].index("S1: IMM/TOMHT's hit rate")]
    assert row[:3] == ["Vargas Avila (2015)", "S1: IMM/TOMHT's hit rate", "99.63 %"]
    assert row[3] == stat_cell(hit, "{:.2f}")
    by_hand = AGREES if hit["ci_low"] <= 99.63 <= hit["ci_high"] else (HIGHER if hit["ci_low"] > 99.63 else LOWER)
    assert row[4] == f"**{by_hand}**"
    for claim, r in zip(CLAIMS, rows, strict=True):
        assert r[4] == f"**{claim.verdict(studies[claim.study]) if r[3] != '-' else NOT_MEASURED}**", claim.text
    for name in reproduce.STUDIES:
        assert f"[its report]({name}/report.html)" in md and (reproduced / name / "report.html").is_file()
    assert '<a href="radar/report.html">its report</a>' in (reproduced / "report.html").read_text()


def test_a_planted_reference_flips_its_verdict(reproduced):
    studies = {name: study_files(reproduced / name) for name in reproduce.STUDIES}
    i = [c.text for c in CLAIMS].index("S1: IMM/TOMHT's hit rate")
    claim = CLAIMS[i]
    stat = claim.stats(studies["radar"])[0]
    inside, above = dataclasses.replace(claim, reference=stat["mean"]), dataclasses.replace(claim, reference=101.0)
    assert claims_table((inside,), studies).rows[0][4] == f"**{AGREES}**"
    assert claims_table((above,), studies).rows[0][4] == f"**{LOWER}**"
    below = {k: stat[k] - (stat["ci_low"] - 1.0) for k in ("mean", "ci_low", "ci_high")}  # the hit rate less 1 below
    higher = Claim(claim.work, "radar", "the hit rate exceeds its lower bound less 1", lambda study: below, sign=+1)
    assert higher.verdict(studies["radar"]) == HOLDS
    assert dataclasses.replace(higher, sign=-1).verdict(studies["radar"]) == REVERSED
    page = write_reproduction(reproduced, {n: reproduced / n for n in reproduce.STUDIES}, "planted",
                              claims=(above, *CLAIMS[:i], *CLAIMS[i + 1:]))
    assert f"| 101.00 % | {stat_cell(stat, '{:.2f}')} | **{LOWER}** |" in page.with_name("report.md").read_text()


def test_an_unknown_study_is_refused_before_anything_runs(tmp_path):
    result = CliRunner().invoke(app, ["reproduce", "--out", str(tmp_path / "o"), "--quick", "--only", "radr"])
    assert result.exit_code != 0 and "radr" in str(result.exception) and not (tmp_path / "o").exists()
