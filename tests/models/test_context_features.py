from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nnda.data.encounters import encounter_scenes
from nnda.data.generator import generate
from nnda.errors import ModelError
from nnda.models.context import CONTEXT_NAMES, D2_CAP, D2_COLUMN, IMM_CONTEXT, context_features, with_context
from nnda.models.innovation import IMM_INNOVATION
from nnda.models.pairs import extract_pairs
from tolerances import RTOL


def brute_force(track, contact, d2):
    d2 = np.minimum(d2, D2_CAP)
    out = np.empty((len(d2), len(CONTEXT_NAMES)))
    for p in range(len(d2)):
        mine = [q for q in range(len(d2)) if track[q] == track[p]]
        others = [d2[q] for q in mine if q != p]
        out[p, 0] = sum(d2[q] < d2[p] or (d2[q] == d2[p] and q < p) for q in mine)
        out[p, 1] = d2[p] - min(others, default=D2_CAP)
        out[p, 2] = len(mine)
        rivals = [d2[q] for q in range(len(d2)) if contact[q] == contact[p] and q != p]
        out[p, 3] = len(rivals)
        out[p, 4] = min(rivals, default=D2_CAP)
    return out


def test_hand_made_scan():
    # two tracks, three contacts: track 0 sees contacts 0, 1, 2 (d² 1, 4, 60 -> capped at 50),
    # track 1 sees contacts 1 and 2 (d² 2, 9)
    track = np.array([0, 0, 1, 1, 0])
    contact = np.array([0, 1, 1, 2, 2])
    d2 = np.array([1.0, 4.0, 2.0, 9.0, 60.0])
    expected = np.array([
        # rank, margin, n candidates, rival tracks, rival d²
        [0, 1 - 4, 3, 0, D2_CAP],
        [1, 4 - 1, 3, 1, 2],
        [0, 2 - 9, 2, 1, 4],
        [1, 9 - 2, 2, 1, D2_CAP],
        [2, D2_CAP - 1, 3, 1, 9],
    ], dtype=float)
    np.testing.assert_allclose(context_features(track, contact, d2), expected, rtol=RTOL)
    assert context_features(track[:0], contact[:0], d2[:0]).shape == (0, 5)
    with pytest.raises(ModelError, match="one shape"):
        context_features(track, contact[:3], d2)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 4), st.integers(0, 5), st.floats(0, 80)), min_size=1, max_size=25))
def test_context_against_brute_force(rows):
    # ties in d² broken by position in both (a stable sort), so the ranks agree exactly
    track, contact, d2 = (np.array(c) for c in zip(*rows))
    np.testing.assert_allclose(context_features(track, contact, d2), brute_force(track, contact, d2), rtol=RTOL)


@pytest.mark.parametrize("seed", range(3))
def test_context_of_many_pairs_with_ties_against_brute_force(seed):
    # hundreds of pairs over large, sparse keys (training's scan x target keys), d² tied in a few values
    rng = np.random.default_rng(seed)
    P = 300
    track, contact = rng.choice(10**6, 40)[rng.integers(0, 40, P)], rng.integers(0, 120, P)
    d2 = rng.choice([0.5, 3.0, 3.0, 49.0, 50.0, 50.5, 70.0], P) if seed else rng.exponential(10.0, P)
    got = context_features(track, contact, d2)
    np.testing.assert_allclose(got, brute_force(track, contact, d2), rtol=RTOL)
    assert got[:, 0].max() > 5 and got[:, 3].max() > 3  # long ranks and many rivals


def test_with_context_appends_the_context_of_the_d2_column():
    rng = np.random.default_rng(4)
    features = rng.normal(0, 1, (30, IMM_INNOVATION.size))
    features[:, D2_COLUMN] = rng.exponential(8.0, 30)
    track, contact = rng.integers(0, 5, 30), rng.integers(0, 12, 30)
    out = with_context(features, track, contact)
    assert out.shape == (30, IMM_CONTEXT.size)
    np.testing.assert_array_equal(out[:, :IMM_INNOVATION.size], features)
    np.testing.assert_array_equal(out[:, IMM_INNOVATION.size:],
                                  context_features(track, contact, features[:, D2_COLUMN]))
    assert with_context(features[:0], track[:0], contact[:0]).shape == (0, IMM_CONTEXT.size)
    with pytest.raises(ModelError, match="one shape"):
        with_context(features, track[:4], contact)


def test_training_pairs_see_the_other_targets_tracks():
    # encounter scenes put two or three targets through one point: their oracle tracks are rivals
    ds = generate(encounter_scenes(1, seed=3)[0], seed=3)
    ctx = extract_pairs(ds, features=IMM_CONTEXT.name)
    ext = extract_pairs(ds, features=IMM_INNOVATION.name)
    np.testing.assert_array_equal(ctx.features[:, :IMM_INNOVATION.size], ext.features)
    for k in np.unique(ctx.scan)[::7]:  # the context is that of each scan's pairs, every target's track a key
        at = ctx.scan == k
        np.testing.assert_allclose(ctx.features[at, IMM_INNOVATION.size:],
                                   brute_force(ctx.target_id[at], ctx.contact[at], ctx.features[at, D2_COLUMN]),
                                   rtol=RTOL)
    assert (ctx.features[:, IMM_INNOVATION.size + 3] > 0).any()  # some contact is claimed by two targets


def test_encounter_scenes_are_seeded_and_meet():
    a, b = encounter_scenes(6, seed=1), encounter_scenes(6, seed=1)
    assert a == b and a != encounter_scenes(6, seed=2)
    assert [s.name.split("-", 1)[1] for s in a] == ["crossing", "parallel", "near-miss"] * 2
    for s in a:
        truth = generate(s, seed=0).truth
        # the closest approach of the first two targets: at most the near-miss's 800 m (+ process noise)
        t0, t1 = (truth.target_id == 0), (truth.target_id == 1)
        gap = np.hypot(truth.x[t0] - truth.x[t1], truth.y[t0] - truth.y[t1])
        assert gap.min() < (1_600.0 if "parallel" in s.name else 900.0), (s.name, gap.min())
