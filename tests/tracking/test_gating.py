"""The chi-square gate: the sparse pairs of every track or of some, on both search paths, against brute force."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.presets import PRESETS
from nnda.filters.imm import IMM
from nnda.tracking import gating
from nnda.tracking.gating import gate
from tolerances import RTOL


def _scene(seed: int, K: int = 12, N: int = 80):
    """K tracks 8-24 km out predicted 2 s ahead, N contacts, half of them near the tracks (polar)."""
    rng = np.random.default_rng(seed)
    imm = IMM.for_sensor(PRESETS["S1"].sensor)
    r, b = rng.uniform(8e3, 2.4e4, K), rng.uniform(0, 2 * np.pi, K)
    p = np.stack([r * np.sin(b), r * np.cos(b)], -1)
    polar = lambda q: np.stack([np.hypot(*q.T), np.arctan2(*q.T) % (2 * np.pi)], -1)  # noqa: E731
    v = rng.normal(0, 150, (K, 2))
    pred = imm.predict(imm.initialise(polar(p), polar(p + 2 * v), 0.0, 2.0), 2.0)
    xy = np.where(rng.random((N, 1)) < 0.5, (p + 4 * v)[rng.integers(0, K, N)] + rng.normal(0, 200, (N, 2)),
                  rng.uniform(-2.4e4, 2.4e4, (N, 2)))
    return imm, pred, polar(xy), xy


@pytest.mark.parametrize("dense", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_the_gate_of_some_tracks_is_brute_forces_pairs_of_those_rows(seed, dense, monkeypatch):
    if not dense:
        monkeypatch.setattr(gating, "DENSE_PAIRS", 0)  # the k-d tree's path
    imm, pred, z, xy = _scene(seed)
    mp = imm.combined_measurement(pred)
    d2 = imm.mahalanobis(mp, z)
    rng = np.random.default_rng(seed)
    for rows in (None, np.sort(rng.choice(len(mp.z), 5, replace=False)), np.empty(0, np.int64)):
        g = gate(imm, mp, z, xy, 9.21, imm.estimate(pred.state), rows=rows)
        wanted = np.arange(len(mp.z)) if rows is None else rows
        r, c = np.nonzero(d2[wanted] <= 9.21)
        np.testing.assert_array_equal(g.rows, wanted[r])
        np.testing.assert_array_equal(g.cols, c)
        if dense:  # the compiled pass and the matrix share `_d2`: the same bits
            np.testing.assert_array_equal(g.d2, d2[wanted[r], c])
        else:  # the k-d tree's path computes d2 in numpy: agreement to rounding
            np.testing.assert_allclose(g.d2, d2[wanted[r], c], rtol=RTOL)
    assert gate(imm, mp, z, xy, 9.21).rows.size > 5


@pytest.mark.parametrize("dense", [True, False])
def test_a_gate_per_track_is_each_tracks_own_gate(dense, monkeypatch):
    if not dense:
        monkeypatch.setattr(gating, "DENSE_PAIRS", 0)
    imm, pred, z, xy = _scene(4)
    mp, estimate = imm.combined_measurement(pred), imm.estimate(pred.state)
    rows = np.arange(0, len(mp.z), 2)
    limits = np.where(rows % 4 == 0, 5.99, 13.82)
    g = gate(imm, mp, z, xy, limits, estimate, rows=rows)
    one = [gate(imm, mp, z, xy, t, estimate, rows=np.array([r])) for r, t in zip(rows, limits)]
    np.testing.assert_array_equal(g.rows, np.concatenate([o.rows for o in one]))
    np.testing.assert_array_equal(g.cols, np.concatenate([o.cols for o in one]))
    wide = gate(imm, mp, z, xy, 13.82, estimate, rows=rows)
    assert g.rows.size < wide.rows.size  # the 5.99 rows lost pairs that 13.82 keeps
    with pytest.raises(ValueError, match="thresholds of shape"):
        gate(imm, mp, z, xy, limits[:-1], estimate, rows=rows)
