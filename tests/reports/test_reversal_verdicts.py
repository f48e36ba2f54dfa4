"""The radar thesis's own comparison (neural association against IMM/TOMHT) read from planted results: where nnda's
numbers repeat the thesis's the claims hold and their reasons say so; where they are reversed the verdicts and the
sentences turn with them."""

from __future__ import annotations

from pathlib import Path

from nnda.reports.claims import HOLDS, REVERSED
from nnda.reports.pages import StudyFiles
from nnda.reports.reproduction import CLAIMS, claims_table, radar_reading

SCENES = [f"S{i}" for i in range(1, 7)]


def _stat(mean: float, half: float = 0.2) -> dict:
    return {"mean": mean, "ci_low": mean - half, "ci_high": mean + half, "n": 10}


def _study(mht: dict, neural: dict) -> StudyFiles:
    """A radar study of S1-S6 whose MHT and nn-seed have the given means (lost targets, confirmed tracks, hit
    rate) in every scenario; nn-life copies the MHT."""
    def trackers() -> dict:
        return {name: {"metrics": {k: _stat(v) for k, v in means.items()}}
                for name, means in (("mht", mht), ("nn-seed", neural), ("nn-life", mht))}
    summary = {"scenarios": [{"name": s, "targets": [{}] * 4, "trackers": trackers()} for s in SCENES]}
    return StudyFiles(Path("/nonexistent"), {}, summary, {})


#: the thesis's picture: MHT loses targets and confirms more tracks, the neural tracker hits more
AS_THE_THESIS = _study({"lost_targets": 2.0, "confirmed_tracks": 9.0, "hit_rate": 95.0},
                       {"lost_targets": 0.0, "confirmed_tracks": 4.0, "hit_rate": 98.0})
#: nnda's picture at the demo's size: the MHT keeps every target, the neural tracker loses and breaks them
AS_NNDA = _study({"lost_targets": 0.1, "confirmed_tracks": 4.1, "hit_rate": 98.2},
                 {"lost_targets": 2.8, "confirmed_tracks": 10.2, "hit_rate": 82.9})


def _rows(study: StudyFiles) -> dict[str, tuple[str, str]]:
    table = claims_table(tuple(c for c in CLAIMS if c.study == "radar"), {"radar": study})
    return {row[1]: (row[4].strip("*"), row[5]) for row in table.rows}


def test_the_comparison_holds_on_the_theses_numbers_and_is_reversed_on_nndas():
    thesis, nnda = _rows(AS_THE_THESIS), _rows(AS_NNDA)
    compared = [t for t in thesis if "the neural association" in t and "IMM/TOMHT" in t and "faster" not in t]
    assert len(compared) == 4
    for text in compared:
        assert thesis[text][0] == HOLDS, text
        assert nnda[text][0] == REVERSED, text
    lost = "S3: the neural association loses fewer targets than IMM/TOMHT (the thesis: none against two; neural " \
           "less MHT)"
    assert "nnda's neural association 0.0 against its MHT's 2.0" in thesis[lost][1]
    assert "as strong a baseline as the thesis's" in thesis[lost][1]
    assert "nnda's neural association 2.8 against its MHT's 0.1" in nnda[lost][1]
    assert "a stronger baseline than the thesis's" in nnda[lost][1]
    assert "a worse tracker than the thesis's" in nnda[lost][1]


def test_a_number_claims_reason_names_the_side_and_the_gap():
    thesis, nnda = _rows(AS_THE_THESIS), _rows(AS_NNDA)
    gap = "S3: IMM/TOMHT loses two targets in the detection gaps"
    assert thesis[gap][1] == "nnda's MHT loses 2.0 targets a run where Vargas Avila (2015)'s lost 2."
    assert nnda[gap][1] == "nnda's MHT loses 0.1 targets a run where Vargas Avila (2015)'s lost 2: a stronger baseline."
    hit = "S3: neural association's hit rate"
    assert nnda[hit] == ("nnda lower", "nnda's mean is 13.34 % below the reference's 96.24 %, and its whole interval "
                                       "[82.70, 83.10] lies below it.")


def test_the_reports_reading_says_which_way_the_comparison_went():
    assert radar_reading(AS_NNDA).startswith("**The thesis's comparison does not hold in nnda** (reversed, reversed, "
                                             "reversed, reversed). nnda's IMM/TOMHT is a much stronger baseline")
    assert "loses 2.8 targets a run (the thesis's neural tracker lost none)" in radar_reading(AS_NNDA)
    assert "lies outside nnda's interval in 6 of 6 scenarios" in radar_reading(AS_NNDA)
    assert radar_reading(AS_THE_THESIS).startswith("**The thesis's comparison holds in nnda** (holds, holds, holds, "
                                                   "holds). nnda's IMM/TOMHT is not a stronger baseline")
