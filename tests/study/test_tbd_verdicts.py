"""The track-before-detect report's verdicts against the paper's acceptance, from planted results: a divergence
count inside the upper 95% bound of the paper's count reads "inside", one beyond it reads "outside" with both
counts and Fisher's p, and the frozen-velocity cause is named only when the filters ran on the frames' own q."""

from __future__ import annotations

import pytest

from nnda.filters.tbd import TBDConfig
from nnda.reports.tbd_section import _exit_reentry_text, _verdict, filter_q
from nnda.study.tbd import FILTER_Q, TBDStudyConfig, divergence, fisher

STEADY = {"mean": 1.0, "ci_low": 0.8, "ci_high": 1.2}


def _setting(apf: int, rs: int, ptcr: float = 6.5) -> dict:
    """One PTCR's results as `nnda.study.tbd_runs.ptcr_results` writes them, with the planted counts of 100."""
    counts = {"apf": (apf, {6.5: 3, 8.1: 2}[ptcr]), "rs": (rs, {6.5: 5, 8.1: 3}[ptcr])}
    filters, paper = {}, {}
    for name, particles in (("apf", 5000), ("rs", 8000)):
        ours, theirs = (divergence(c, 100, 0.95) for c in counts[name])
        label = f"{name}@{particles}"
        filters[label] = {"filter": name, "divergence": ours, "steady_error": STEADY,
                          "evaluations_per_frame": 2.0 * particles}
        paper[label] = {"divergence": theirs, "fisher_p": fisher(ours, theirs)}
    pair = {"a": "apf@5000", "b": "rs@8000",
            "fisher_p": fisher(filters["apf@5000"]["divergence"], filters["rs@8000"]["divergence"])}
    return {"ptcr_db": ptcr, "filters": filters, "paper": paper, "pairs": [pair]}


def _cfg(q: float | None) -> dict:
    return {"confidence": 0.95, "tbd": {"q": q}, "scene": {"q": 6.0, "dt": 0.04, "birth_velocity_sd": 5.0}}


def test_a_count_beyond_the_papers_bound_is_called_outside_with_both_counts_and_p():
    text = _verdict(_setting(14, 5), _cfg(None))
    assert ("**apf@5000 at 6.5 dB is outside the paper's acceptance**: 14/100 divergent runs (14.0%) against the "
            "paper's 3/100 (Fisher p = 0.009)") in text
    assert "at most 8.5%, the upper 95% bound of the paper's count" in text
    assert "rs@8000 at 6.5 dB: 5/100 divergent runs (5.0%) against the paper's 5/100 (Fisher p = 1.000), inside" \
        in text
    # the frames' own q: the measured cause, with the velocity step it allows
    assert "frames' own q = 6 px^2 per time unit^3" in text and "0.49 px per time unit a frame" in text


def test_a_count_inside_the_bound_is_called_inside_and_the_sentence_changes():
    inside = _verdict(_setting(8, 5), _cfg(FILTER_Q))  # 8% <= 8.5%, the upper bound of 3/100
    assert "apf@5000 at 6.5 dB: 8/100 divergent runs (8.0%) against the paper's 3/100 (Fisher p = 0.213), " \
           "inside the paper's acceptance" in inside
    assert "outside" not in inside
    outside = _verdict(_setting(9, 5), _cfg(FILTER_Q))  # 9% > 8.5%
    assert "**apf@5000 at 6.5 dB is outside the paper's acceptance**: 9/100" in outside
    assert "frames' own q" not in outside  # the filters' q was not the frames': no frozen-velocity cause


def test_the_bound_is_the_papers_at_each_ptcr():
    text = _verdict(_setting(8, 3, ptcr=8.1), _cfg(FILTER_Q))  # the paper's 2/100 at 8.1 dB: bound 7.0%
    assert "**apf@5000 at 8.1 dB is outside the paper's acceptance**: 8/100" in text
    assert "at most 7.0%" in text and "rs@8000 at 8.1 dB: 3/100" in text and "inside" in text


def test_filter_q_reads_old_results_as_the_frames_q():
    assert filter_q(_cfg(None)) == 6.0 and filter_q(_cfg(150.0)) == 150.0
    assert filter_q({"tbd": {}, "scene": {"q": 6.0}}) == 6.0


def test_exit_reentry_text_names_false_detections_and_missed_reacquisitions():
    er = {"filters": {"apf@5000": {"false_detection_rate": 0.201, "absent_frames": 273,
                                   "reacquire": {"never": 6, "events": 20}}}}
    assert ("apf@5000 declares 20.1% of the 273 target-free frames present and never reacquires 6 of 20 "
            "re-entries") in _exit_reentry_text(er)


def test_the_study_runs_its_filters_on_their_own_q_unless_told():
    assert TBDStudyConfig().tbd.q == FILTER_Q
    assert TBDStudyConfig(tbd={"gmrf": "estimated"}).tbd.q == FILTER_Q  # a table without q keeps the study's
    assert TBDStudyConfig(tbd={"q": 6.0}).tbd.q == 6.0
    assert TBDConfig().q is None  # the filter alone: the frames' q
    with pytest.raises(ValueError, match="q"):
        TBDConfig(q=0.0)
