"""Aggregation over runs on inputs with known answers."""

from __future__ import annotations

import math

import pytest

from nnda.study.stats import mean_ci
from nnda.study.stats import ragged_mean as _nanmean_rows

#: Student t quantiles from printed tables: t(0.975; 3) and t(0.95; 9)
T_975_3 = 3.182446
T_95_9 = 1.833113


def test_mean_and_t_interval_of_known_values():
    r = mean_ci([1.0, 2.0, 3.0, 4.0])
    half = T_975_3 * math.sqrt(5 / 3) / 2  # sample sd sqrt(5/3), n = 4
    assert r["mean"] == 2.5 and r["n"] == 4
    assert r["ci_low"] == pytest.approx(2.5 - half, rel=1e-6)
    assert r["ci_high"] == pytest.approx(2.5 + half, rel=1e-6)
    r90 = mean_ci(list(range(10)), confidence=0.90)
    assert r90["ci_high"] - r90["mean"] == pytest.approx(T_95_9 * math.sqrt(55 / 6) / math.sqrt(10), rel=1e-6)


def test_undefined_runs_are_left_out_and_counted():
    assert mean_ci([None, 4.0, float("nan"), 6.0])["n"] == 2
    assert mean_ci([None, 4.0, float("nan"), 6.0])["mean"] == 5.0
    one = mean_ci([7.0, None])
    assert (one["mean"], one["ci_low"], one["ci_high"], one["n"]) == (7.0, None, None, 1)
    assert mean_ci([None, None]) == {"mean": None, "ci_low": None, "ci_high": None, "n": 0}


def test_interval_is_cut_to_the_possible_range_and_zero_when_runs_agree():
    r = mean_ci([0.0, 0.0, 3.0], low=0.0)
    assert r["ci_low"] == 0.0 and r["ci_high"] > 3.0 and r["mean"] == 1.0
    assert mean_ci([99.0, 100.0], low=0.0, high=100.0)["ci_high"] == 100.0
    same = mean_ci([4, 4, 4])
    assert same["ci_low"] == same["ci_high"] == same["mean"] == 4.0


def test_per_scan_series_average_over_runs_of_unequal_length():
    assert _nanmean_rows([[1.0, 2.0, 3.0], [3.0, 4.0]]) == [2.0, 3.0, 3.0]
    assert _nanmean_rows([[1.0, float("nan")], [3.0, float("nan")]]) == [2.0, None]
