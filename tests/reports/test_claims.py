"""A claim's verdict read from nnda's intervals: numbers against the reference, comparisons against 0."""

from __future__ import annotations

import pytest

from nnda.reports.claims import (
    AGREES,
    HIGHER,
    HOLDS,
    LOWER,
    NOT_MEASURED,
    NOT_SHOWN,
    REVERSED,
    Claim,
    difference,
    number_verdict,
    sign_verdict,
)


def stat(low, high):
    return {"mean": None if low is None else (low + high) / 2, "ci_low": low, "ci_high": high}


@pytest.mark.parametrize("reference, low, high, verdict", [
    (5.0, 4.0, 6.0, AGREES), (5.0, 4.0, 5.0, AGREES), (5.0, 5.5, 6.0, HIGHER), (5.0, 1.0, 4.9, LOWER),
    (5.0, None, None, NOT_MEASURED)])
def test_a_number_agrees_when_nndas_interval_holds_it(reference, low, high, verdict):
    assert number_verdict(reference, stat(low, high)) == verdict


@pytest.mark.parametrize("intervals, sign, verdict", [
    ([(1.0, 2.0), (0.5, 3.0)], 1, HOLDS), ([(1.0, 2.0), (-0.5, 3.0)], 1, NOT_SHOWN),
    ([(1.0, 2.0), (-3.0, -0.5)], 1, REVERSED), ([(-2.0, -1.0)], -1, HOLDS), ([(-2.0, -1.0)], 1, REVERSED),
    ([(None, None)], 1, NOT_MEASURED)])
def test_a_comparison_holds_when_every_difference_lies_on_its_side(intervals, sign, verdict):
    assert sign_verdict([stat(*i) for i in intervals], sign) == verdict


@pytest.mark.parametrize("a, b, better, verdict", [
    ((1.0, 2.0), (3.0, 4.0), -1, HOLDS), ((1.0, 2.0), (3.0, 4.0), 1, REVERSED), ((1.0, 3.5), (3.0, 4.0), -1, NOT_SHOWN),
    ((5.0, 6.0), (3.0, 4.0), 1, HOLDS), ((None, None), (3.0, 4.0), 1, NOT_MEASURED)])
def test_two_summaries_differ_only_with_their_intervals_apart(a, b, better, verdict):
    assert sign_verdict([difference(stat(*a), stat(*b))], better) == verdict


def test_a_claim_is_a_number_or_a_comparison():
    with pytest.raises(ValueError, match="not both and not neither"):
        Claim("W", "s", "t", lambda study: stat(1, 2))
    with pytest.raises(ValueError, match="not both and not neither"):
        Claim("W", "s", "t", lambda study: stat(1, 2), reference=1.0, sign=1)
    claim = Claim("W", "s", "t", lambda study: stat(1.0, 2.0), reference=1.5, unit="%", fmt="{:.1f}")
    assert claim.verdict(None) == AGREES and claim.reference_cell() == "1.5 %"
    assert claim.nnda_cell(None) == "1.5 [1.0, 2.0]"


def test_the_generic_reason_names_the_side_the_gap_and_the_count_of_differences():
    number = Claim("W", "s", "t", lambda study: {"mean": 3.0, "ci_low": 2.5, "ci_high": 3.5}, reference=2.0, unit="m",
                   fmt="{:.1f}")
    assert number.reason_text(None) == ("nnda's mean is 1.0 m above the reference's 2.0 m, and its whole interval "
                                        "[2.5, 3.5] lies above it.")
    inside = Claim("W", "s", "t", lambda study: {"mean": 2.1, "ci_low": 1.5, "ci_high": 2.5}, reference=2.0,
                   fmt="{:.1f}")
    assert inside.reason_text(None) == "the reference's 2.0 lies inside nnda's interval [1.5, 2.5]."
    pair = Claim("W", "s", "t", lambda study: [stat(1.0, 2.0), stat(-3.0, -1.0)], sign=1, fmt="{:+.1f}")
    assert pair.verdict(None) == REVERSED
    assert pair.reason_text(None) == ("1 of 2 differences lie wholly above 0 as claimed, 1 wholly on the other side, "
                                      "0 hold 0 (means +1.5, -2.0).")
    custom = Claim("W", "s", "t", lambda study: stat(1.0, 2.0), sign=1, reason=lambda study: "planted.")
    assert custom.reason_text(None) == "planted."
