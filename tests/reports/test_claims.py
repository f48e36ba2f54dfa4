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
