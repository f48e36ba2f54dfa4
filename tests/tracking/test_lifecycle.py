"""M/N confirmation, deletion and the initiation window."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from nnda.tracking.lifecycle import (
    LifecycleConfig,
    advance,
    advance_score,
    cap_per_initiator,
    free_window_pairs,
    sprt_thresholds,
    window_pairs,
)
from nnda.tracking.output import TrackStatus as S

# Spec Table 2.1 (M = 2, N = 3): detection history from scan 3 on -> class
TABLE_2_1 = {
    "0": S.PRELIMINARY, "1": S.PRELIMINARY,
    "00": S.DELETED, "01": S.PRELIMINARY, "10": S.PRELIMINARY, "11": S.CONFIRMED,
    "010": S.DELETED, "011": S.CONFIRMED, "100": S.DELETED, "101": S.CONFIRMED,
}


def _run(history: str, cfg: LifecycleConfig) -> S:
    status, hits, misses, consec = (np.array([S.PRELIMINARY]), np.zeros(1, int), np.zeros(1, int), np.zeros(1, int))
    for c in history:
        if status[0] == S.DELETED:
            break
        status, hits, misses, consec = advance(status, hits, misses, consec, np.array([c == "1"]), cfg)
    return S(status[0])


@pytest.mark.parametrize("history, expected", sorted(TABLE_2_1.items()))
def test_table_2_1(history, expected):
    assert _run(history, LifecycleConfig(m=2, n=3)) == expected


def test_spec_3_of_4_and_confirmed_track_survives_three_misses():
    cfg = LifecycleConfig()
    assert _run("111", cfg) == S.CONFIRMED
    assert _run("1011", cfg) == S.CONFIRMED
    assert _run("1001", cfg) == S.DELETED
    assert _run("111" + "000", cfg) == S.CONFIRMED
    assert _run("111" + "0001" + "000", cfg) == S.CONFIRMED
    assert _run("111" + "0000", cfg) == S.DELETED
    assert _run("111" + "000", cfg.model_copy(update={"max_misses": 2})) == S.DELETED


def test_batch_equals_single_tracks():
    rng = np.random.default_rng(0)
    cfg = LifecycleConfig()
    histories = ["".join(rng.choice(["0", "1"], 10)) for _ in range(50)]
    n = len(histories)
    status, hits, misses, consec = np.full(n, S.PRELIMINARY), np.zeros(n, int), np.zeros(n, int), np.zeros(n, int)
    final = status.copy()
    for k in range(10):
        alive = status != S.DELETED
        det = np.array([h[k] == "1" for h in histories])
        new = advance(status[alive], hits[alive], misses[alive], consec[alive], det[alive], cfg)
        for arr, val in zip((status, hits, misses, consec), new):
            arr[alive] = val
        final = status
    assert [S(s) for s in final] == [_run(h, cfg) for h in histories]


def test_window_matches_published_tracking():
    assert LifecycleConfig().window(2.0, 30.0) == (50.0, 490.0)
    assert LifecycleConfig(v_min=50, v_max=500).window(2.0, 30.0) == (10.0, 1090.0)


@pytest.mark.parametrize("n_a, n_b", [(60, 80), (300, 250), (1500, 1500)])
def test_window_pairs_against_brute_force(n_a, n_b):
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 5000, (n_a, 2))
    b = rng.uniform(0, 5000, (n_b, 2))
    i, j = window_pairs(a, b, 50.0, 490.0)
    d = np.linalg.norm(a[:, None] - b[None], axis=2)
    ei, ej = np.nonzero((d >= 50) & (d <= 490))
    np.testing.assert_array_equal(i, ei)
    np.testing.assert_array_equal(j, ej)
    e = window_pairs(np.empty((0, 2)), b, 50, 490)
    assert e[0].size == 0 and e[1].size == 0


def test_free_window_pairs_are_those_of_the_unused_contacts():
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 3000, (40, 2)), rng.uniform(0, 3000, (60, 2))
    used = rng.random(60) < 0.3
    free, i, j = free_window_pairs(a, b, used, 50.0, 490.0)
    np.testing.assert_array_equal(free, np.flatnonzero(~used))
    d = np.linalg.norm(a[:, None] - b[None, free], axis=2)
    ei, ej = np.nonzero((d >= 50) & (d <= 490))
    np.testing.assert_array_equal(i, ei)
    np.testing.assert_array_equal(j, ej)
    for none in (free_window_pairs(a, b, np.ones(60, bool), 50.0, 490.0),
                 free_window_pairs(np.empty((0, 2)), b, used, 50.0, 490.0)):
        assert none[1].size == 0 and none[2].size == 0


def test_window_pairs_with_initiators_off_the_contacts_and_contacts_far_apart():
    # strips doubled (contacts 2,000 km apart), initiators left, right and inside of the contacts' x span
    rng = np.random.default_rng(2)
    b = np.concatenate([rng.uniform(0, 3000, (40, 2)), [[2e6, 100.0], [2e6 + 300.0, 0.0], [-1e6, 0.0]]])
    a = np.concatenate([rng.uniform(-500, 3500, (30, 2)), [[2e6 + 100.0, 0.0], [-1e6 - 200.0, 0.0], [5e6, 0.0]]])
    i, j = window_pairs(a, b, 50.0, 490.0)
    d = np.linalg.norm(a[:, None] - b[None], axis=2)
    ei, ej = np.nonzero((d >= 50) & (d <= 490))
    np.testing.assert_array_equal(i, ei)
    np.testing.assert_array_equal(j, ej)
    assert {30, 31} <= set(i.tolist())  # the far initiators found their far contacts


def test_bad_lifecycle_config():
    with pytest.raises(ValidationError, match="m <= n"):
        LifecycleConfig(m=5, n=4)
    with pytest.raises(ValidationError, match="v_min must be below v_max"):
        LifecycleConfig(v_min=300)


def test_cap_per_initiator_keeps_the_pairs_nearest_the_window_middle():
    init = np.array([[0.0, 0.0], [10_000.0, 0.0]])
    contacts = np.array([[100.0, 0.0], [260.0, 0.0], [300.0, 0.0], [480.0, 0.0], [10_200.0, 0.0]])
    i, j = window_pairs(init, contacts, 50.0, 490.0)
    assert i.tolist() == [0, 0, 0, 0, 1]
    ci, cj = cap_per_initiator(i, j, init, contacts, 50.0, 490.0, 2)
    assert ci.tolist() == [0, 0, 1] and cj.tolist() == [1, 2, 4]  # 260 and 300 m are nearest 270 m
    same = cap_per_initiator(i, j, init, contacts, 50.0, 490.0, 0)
    assert same[0].tolist() == i.tolist() and same[1].tolist() == j.tolist()


def _one_track(status, hits, misses, consecutive, detected, cfg):
    """The M/N rule for one track, written out (the oracle of `advance`)."""
    hits, misses = hits + detected, misses + (not detected)
    consecutive = 0 if detected else consecutive + 1
    if status == S.PRELIMINARY and misses >= cfg.n - cfg.m + 1:
        status = S.DELETED
    elif status == S.PRELIMINARY and hits >= cfg.m:
        status = S.CONFIRMED
    if status == S.CONFIRMED and consecutive > cfg.max_misses:
        status = S.DELETED
    return status, hits, misses, consecutive


def _one_score(status, score, max_score, confirm_at, cfg):
    """The score and existence rules for one track, written out (the oracle of `advance_score`)."""
    early = sprt_thresholds(cfg.false_confirmation, cfg.preliminary_false_deletion)[0]
    if cfg.confirmation == "existence":
        logit = [math.log(p / (1 - p)) for p in (cfg.existence_deletion, cfg.existence_confirmation)]
        if status == S.PRELIMINARY:
            return S.DELETED if score - max_score <= early else S.CONFIRMED if score >= logit[1] else status
        return S.DELETED if status == S.CONFIRMED and score <= logit[0] else status
    lower, upper = cfg.score_thresholds
    if status == S.PRELIMINARY:
        upper = upper if confirm_at is None else confirm_at
        return S.DELETED if score <= early else S.CONFIRMED if score >= upper else status
    return S.DELETED if status == S.CONFIRMED and score - max_score <= lower else status


tracks = st.integers(0, 30)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), K=tracks, m=st.integers(1, 4), extra=st.integers(0, 3),
       max_misses=st.integers(0, 4), some_unobserved=st.booleans())
def test_advance_equals_the_rule_track_by_track(seed, K, m, extra, max_misses, some_unobserved):
    rng = np.random.default_rng(seed)
    cfg = LifecycleConfig(m=m, n=m + extra, max_misses=max_misses)
    status = rng.choice([S.PRELIMINARY, S.CONFIRMED], K).astype(np.int8)
    hits, misses, consecutive = (rng.integers(0, 6, K) for _ in range(3))
    detected = rng.random(K) < 0.5
    observed = rng.random(K) < 0.7 if some_unobserved else None
    before = [a.copy() for a in (status, hits, misses, consecutive)]
    got = advance(status, hits, misses, consecutive, detected, cfg, observed)
    for a, b in zip((status, hits, misses, consecutive), before):
        np.testing.assert_array_equal(a, b)  # the inputs are not written
    assert got[0].dtype == np.int8 and all(a.dtype == np.int64 for a in got[1:])
    for k in range(K):
        want = ((status[k], hits[k], misses[k], consecutive[k]) if observed is not None and not observed[k] else
                _one_track(status[k], hits[k], misses[k], consecutive[k], detected[k], cfg))
        assert tuple(int(a[k]) for a in got) == tuple(int(w) for w in want), k


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), K=tracks, rule=st.sampled_from(["score", "existence"]),
       per_track=st.booleans(), some_unobserved=st.booleans())
def test_advance_score_equals_the_rule_track_by_track(seed, K, rule, per_track, some_unobserved):
    rng = np.random.default_rng(seed)
    cfg = LifecycleConfig(confirmation=rule)
    status = rng.choice([S.PRELIMINARY, S.CONFIRMED, S.DELETED], K).astype(np.int8)
    max_score = rng.uniform(-5.0, 20.0, K)
    score = max_score - rng.choice([0.0, 1.0, 3.0, 8.0], K) * rng.random(K)
    score[rng.random(K) < 0.2] = -2.0  # some scores at the thresholds' scale
    confirm_at = rng.uniform(5.0, 15.0, K) if per_track else None
    observed = rng.random(K) < 0.7 if some_unobserved else None
    got = advance_score(status, score, max_score, cfg, observed, confirm_at)
    assert got.dtype == np.int8
    for k in range(K):
        want = (status[k] if observed is not None and not observed[k] else
                _one_score(status[k], score[k], max_score[k], None if confirm_at is None else confirm_at[k], cfg))
        assert int(got[k]) == int(want), k
