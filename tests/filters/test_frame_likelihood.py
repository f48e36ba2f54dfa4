"""The fast frame LLR against the dense Gaussian log-likelihood ratio, at interior, border and partly
outside positions, every aspect, known GMRF parameters per run."""

from __future__ import annotations

import numpy as np
import pytest
from tests.data.test_gmrf import dense_A
from tests.tolerances import RTOL

from nnda.data import gmrf
from nnda.data.frames import DEFAULT_ASPECTS, place, template_library
from nnda.errors import FilterError
from nnda.filters.frame_likelihood import FrameLikelihood, detections


def dense_llr(Y, template, r, c, bh, bv, sigma_c):
    """-1/2 (y - h)^T Sigma^-1 (y - h) + 1/2 y^T Sigma^-1 y, Sigma^-1 = A / sigma_c^2 (the oracle)."""
    H = np.zeros(Y.shape)
    place(H, template, r, c)
    P = dense_A(Y.shape, bh, bv) / sigma_c**2
    y, h = Y.ravel(), H.ravel()
    return -0.5 * (y - h) @ P @ (y - h) + 0.5 * y @ P @ y


@pytest.mark.parametrize("shape", [(9, 11), (7, 7), (12, 8)])
def test_fast_llr_equals_the_dense_gaussian_llr_everywhere(shape):
    rng = np.random.default_rng(sum(shape))
    templates = 2.5 * template_library(DEFAULT_ASPECTS[:2], half=2)[:, :, 1:4]  # 5 x 3: rectangular
    lik = FrameLikelihood(templates, shape)
    bh, bv, sc = np.array([0.22, -0.1]), np.array([0.2, 0.15]), np.array([1.3, 0.7])
    Y = np.stack([gmrf.sample(shape, bh[r], bv[r], sc[r], rng) for r in range(2)])
    L, M = shape
    # every extended-grid centroid (interior, border, partly outside), a few just off it, both aspects
    rows, cols = np.meshgrid(np.arange(-4, L + 4), np.arange(-3, M + 3), indexing="ij")
    x = np.tile(rows.ravel() + rng.uniform(-0.45, 0.45, rows.size), (2, 1))
    y = np.tile(cols.ravel() + rng.uniform(-0.45, 0.45, rows.size), (2, 1))
    z = rng.integers(0, 3, x.shape).astype(float)
    state = np.zeros((*x.shape, 5))  # the particles' [row, v_row, column, v_column, aspect], as the filter holds
    state[..., 0], state[..., 2], state[..., 4] = x, y, z  # them: llr reads their columns (one compiled version)
    got = lik.llr(lik.pad(gmrf.differential(Y, bh, bv)), bh, bv, sc, state[..., 0], state[..., 2], state[..., 4])
    for r in range(2):
        for n in range(x.shape[1]):
            want = 0.0 if z[r, n] == 0 else dense_llr(Y[r], templates[int(z[r, n]) - 1], int(np.rint(x[r, n])),
                                                     int(np.rint(y[r, n])), bh[r], bv[r], sc[r])
            assert got[r, n] == pytest.approx(want, rel=RTOL, abs=RTOL * 10), (r, x[r, n], y[r, n], z[r, n])
    off = (np.rint(x) < -2) | (np.rint(x) > L + 1) | (np.rint(y) < -1) | (np.rint(y) > M)
    assert off.any() and (got[off] == 0).all()
    assert (got[(z > 0) & ~off] != 0).all()


def test_energy_of_an_interior_template_is_h_A_h():
    t = template_library()[1]
    lik = FrameLikelihood(t[None], (20, 20))
    H = np.zeros((20, 20))
    place(H, t, 10, 9)
    A = dense_A((20, 20), 0.22, 0.2)
    rho = lik.rho0[0, 13, 12] - 2 * (0.22 * lik.rhoh[0, 13, 12] + 0.2 * lik.rhov[0, 13, 12])
    assert rho == pytest.approx(H.ravel() @ A @ H.ravel(), rel=RTOL)


def test_bad_templates_and_frames_are_refused():
    with pytest.raises(FilterError, match="larger than the frame"):
        FrameLikelihood(np.ones((1, 7, 7)), (5, 20))
    with pytest.raises(FilterError, match="odd height and width"):
        FrameLikelihood(np.ones((1, 4, 3)), (9, 9))
    with pytest.raises(FilterError, match="non-finite"):
        FrameLikelihood(np.full((1, 3, 3), np.nan), (9, 9))
    with pytest.raises(FilterError, match="frames of"):
        FrameLikelihood(np.ones((1, 3, 3)), (9, 9)).pad(np.zeros((2, 9, 8)))


def test_matched_filter_is_lambda_over_its_sd_and_false_alarms_match_pfa():
    """t = y^T A h / (sigma_c sqrt(h^T A h)) at every position (dense oracle on a small grid), N(0, 1) without a
    target: the share of positions and aspects above Phi^-1(1 - pfa) is pfa."""
    from scipy.special import ndtri

    shape, bh, bv, sc = (9, 10), 0.22, 0.2, 1.3
    templates = 2.0 * template_library(DEFAULT_ASPECTS[:2], half=1)
    lik = FrameLikelihood(templates, shape)
    Y = gmrf.sample(shape, bh, bv, sc, np.random.default_rng(1), (1,))
    B = np.array([bh]), np.array([bv]), np.array([sc])
    t = lik.matched_filter(lik.pad(gmrf.differential(Y, B[0], B[1])), *B)
    A = dense_A(shape, bh, bv)
    for k in range(2):
        for i in range(-1, 10):
            for j in range(-1, 11):
                H = np.zeros(shape)
                place(H, templates[k], i, j)
                h = H.ravel()
                want = Y[0].ravel() @ A @ h / (sc * np.sqrt(h @ A @ h))
                assert t[0, k, i + 1, j + 1] == pytest.approx(want, rel=RTOL, abs=RTOL)
    big = gmrf.sample((64, 64), bh, bv, sc, np.random.default_rng(2), (40,))
    lik = FrameLikelihood(templates, (64, 64))
    R = np.full(40, bh), np.full(40, bv), np.full(40, sc)
    t = lik.matched_filter(lik.pad(gmrf.differential(big, R[0], R[1])), *R)
    share = (t >= ndtri(1 - 0.01)).mean()
    assert share == pytest.approx(0.01, abs=4 * np.sqrt(0.01 / t.size) * 3)  # positions are correlated: x3


def test_detections_are_thresholded_local_maxima():
    t = np.full((1, 2, 6, 7), -1.0)
    t[0, 1, 2, 3], t[0, 0, 2, 4], t[0, 0, 5, 0] = 5.0, 4.0, 3.0  # a peak, its weaker neighbour, a corner peak
    hits = detections(t, (1, 1), pfa=1e-3)  # threshold 3.09
    np.testing.assert_array_equal(hits, [[0, 1, 2, 2, 5.0]])
    assert detections(t, (1, 1), pfa=0.01).shape == (2, 5)  # threshold 2.33: the corner too
    with pytest.raises(FilterError, match="pfa"):
        detections(t, (1, 1), pfa=0.0)
