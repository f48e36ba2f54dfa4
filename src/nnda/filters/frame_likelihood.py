"""The log-likelihood ratio of an image frame given a target (Bruno, Araújo & Pavlov, eqs. 9-11), read from the
differential-filtered frame at the template's offsets, for every particle of R runs in one compiled call.

    lik = FrameLikelihood(templates, (L, M))           # templates (A, 2hr+1, 2hc+1), aspects 1..A
    dp = lik.pad(gmrf.differential(Y, bh, bv))         # (R, L + 4hr, M + 4hc) d = A y, zero padded
    llr = lik.llr(dp, bh, bv, sigma_c, x, y, z)        # (R, N) log p(y | s, z) - log p(y | absent)
    t = lik.matched_filter(dp, bh, bv, sigma_c)        # (R, A, L + 2hr, M + 2hc) the detector's statistic
    hits = detections(t, lik.half, pfa=1e-4)           # (n, 5) run, row, column, aspect, t: per-frame detections

For a centroid (x row, y column; s* = round) and aspect z >= 1, with H the
template placed at s* and clipped at the frame's borders and A the GMRF
matrix (`nnda.data.gmrf`):

    llr = (2 lambda - rho) / (2 sigma_c^2),  lambda = sum H d = y^T A h,
    rho = h^T A h = sum H^2 - 2 beta_h sum H(r, j) H(r, j+1) - 2 beta_v sum H(r, j) H(r+1, j),

the dense Gaussian -1/2 (y - h)^T Sigma^-1 (y - h) + 1/2 y^T Sigma^-1 y with
Sigma^-1 = A / sigma_c^2. Clipping replaces the border table of the paper's
reference: lambda reads d padded with zeros, so template pixels outside the
frame add nothing, and rho is rho0 - 2 beta_h rho_h - 2 beta_v rho_v with
the three sums tabulated once per aspect and extended-grid position (they
do not depend on beta). An absent particle (z = 0) or one off the extended
grid has llr 0. beta_h, beta_v and sigma_c are given per run (R,), known
or estimated per frame.

The conventional chain's detector (thresholding the d-filtered
frame) is the matched filter of every aspect at every extended-grid
position, t = lambda / (sigma_c sqrt(rho)), N(0, 1) without a target
(Var lambda = sigma_c^2 rho); `detections` keeps the positions whose best
aspect's t passes Phi^-1(1 - pfa) (pfa per position and aspect) and is the
largest of its 3 x 3 neighbourhood.

The kernel is numba-compiled, parallel over particles from `PARALLEL_FROM`
particles a call (serial below: a filter of one run); numpy's gather of
(R N, 2hr+1, 2hc+1) values and its reduction run several times slower (see
`benchmarks/bench_tbd.py`, which keeps that numpy version as the reference).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.special import ndtri

from nnda.errors import FilterError
from nnda.validation import check_array, check_finite


@numba.njit(parallel=True, cache=True, nogil=True, fastmath=True)
def _llr(d, values, offsets, counts, half, rho0, rhoh, rhov, bh, bv, sigma_c, x, y, z, out):
    """The compiled loop (module docstring): d (R, Lp, Mp) padded; aspect k's nonzero template pixels
    values[k, :counts[k]] at flat offsets offsets[k, :counts[k]] from the template's corner in d."""
    R, N = x.shape
    A = counts.shape[0]
    Lp, Mp = d.shape[1], d.shape[2]
    Le, Me = rho0.shape[1], rho0.shape[2]
    flat = d.ravel()
    for i in numba.prange(R * N):
        r, n = i // N, i % N
        k = np.int64(z[r, n]) - 1
        out[r, n] = 0.0
        if k < 0 or k >= A:
            continue
        row = np.int64(np.rint(x[r, n])) + half[0]  # the index on the extended grid
        col = np.int64(np.rint(y[r, n])) + half[1]
        if row < 0 or row >= Le or col < 0 or col >= Me:
            continue
        base = np.uint64((r * Lp + row) * Mp + col)  # unsigned: no negative-index wraparound test per read
        lam = 0.0
        for p in range(counts[k]):
            lam += values[k, p] * flat[base + offsets[k, p]]
        rho = rho0[k, row, col] - 2.0 * (bh[r] * rhoh[k, row, col] + bv[r] * rhov[k, row, col])
        out[r, n] = (lam - 0.5 * rho) / (sigma_c[r] * sigma_c[r])


#: calls with fewer particles run on one thread: waking the others costs more than it saves there (one run's
#: 5,000 particles), and far more on a loaded machine
PARALLEL_FROM = 100_000


class FrameLikelihood:
    """The LLR of A aspects' ``templates`` (A, h, w), h and w odd and centred, on frames of ``shape`` (L, M)
    (module docstring); FilterError for a template larger than the frame or a non-finite one."""

    def __init__(self, templates: np.ndarray, shape: tuple[int, int]) -> None:
        a = check_array("FrameLikelihood.templates", templates, (None, None, None), error=FilterError)
        check_finite("FrameLikelihood.templates", a, error=FilterError)
        A, h, w = a.shape
        L, M = shape
        if A < 1 or h % 2 == 0 or w % 2 == 0:
            raise FilterError(f"FrameLikelihood.templates: need at least one template of odd height and width "
                              f"(centred), got shape {a.shape}")
        if h > L or w > M:
            raise FilterError(f"FrameLikelihood.templates: a template ({h} x {w}) is larger than the frame "
                              f"({L} x {M})")
        self.templates, self.shape = np.ascontiguousarray(a), (L, M)
        self.half = (h // 2, w // 2)
        self.rho0, self.rhoh, self.rhov = self._energy_tables()
        # each aspect's nonzero pixels and their flat offsets in a padded frame (M + 4hc columns)
        nonzero = [np.flatnonzero(t) for t in a]
        self.counts = np.array([idx.size for idx in nonzero], dtype=np.int64)
        self.values = np.zeros((A, max(self.counts.max(), 1)))
        self.offsets = np.zeros(self.values.shape, dtype=np.uint64)
        for k, idx in enumerate(nonzero):
            self.values[k, :idx.size] = a[k].ravel()[idx]
            self.offsets[k, :idx.size] = (idx // w) * (M + 4 * self.half[1]) + idx % w

    @property
    def n_aspects(self) -> int:
        return self.templates.shape[0]

    def _energy_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """rho0, rho_h, rho_v (A, L + 2hr, M + 2hc) over the extended grid (row index s*(1) + hr)."""
        (L, M), (hr, hc), a = self.shape, self.half, self.templates
        Le, Me = L + 2 * hr, M + 2 * hc
        inside = np.zeros((L + 4 * hr + 1, M + 4 * hc + 1))
        inside[2 * hr:2 * hr + L, 2 * hc:2 * hc + M] = 1.0
        tables = np.zeros((3, a.shape[0], Le, Me))
        for u in range(2 * hr + 1):
            for v in range(2 * hc + 1):
                here = inside[u:u + Le, v:v + Me]
                tables[0] += a[:, u, v, None, None] ** 2 * here
                if v + 1 < a.shape[2]:  # the pair (u, v), (u, v + 1), both in the frame
                    right = here * inside[u:u + Le, v + 1:v + 1 + Me]
                    tables[1] += (a[:, u, v] * a[:, u, v + 1])[:, None, None] * right
                if u + 1 < a.shape[1]:  # the pair (u, v), (u + 1, v)
                    below = here * inside[u + 1:u + 1 + Le, v:v + Me]
                    tables[2] += (a[:, u, v] * a[:, u + 1, v])[:, None, None] * below
        return tables[0], tables[1], tables[2]

    def pad(self, d: np.ndarray) -> np.ndarray:
        """d (..., L, M) zero padded by 2hr rows and 2hc columns on each side, C-contiguous float64."""
        hr, hc = self.half
        if d.shape[-2:] != self.shape:
            raise FilterError(f"FrameLikelihood.pad: frames of {d.shape[-2:]} pixels, the model's are {self.shape}")
        width = [(0, 0)] * (d.ndim - 2) + [(2 * hr, 2 * hr), (2 * hc, 2 * hc)]
        return np.ascontiguousarray(np.pad(np.asarray(d, dtype=np.float64), width))

    def matched_filter(self, d_pad: np.ndarray, beta_h: np.ndarray, beta_v: np.ndarray,
                       sigma_c: np.ndarray) -> np.ndarray:
        """t (R, A, L + 2hr, M + 2hc) at every aspect and extended-grid position (module docstring)."""
        (hr, hc), a = self.half, self.templates
        Le, Me = self.rho0.shape[1:]
        lam = np.zeros((d_pad.shape[0], a.shape[0], Le, Me))
        for u in range(2 * hr + 1):
            for v in range(2 * hc + 1):
                lam += a[None, :, u, v, None, None] * d_pad[:, None, u:u + Le, v:v + Me]
        rho = self.rho0 - 2.0 * (beta_h[:, None, None, None] * self.rhoh + beta_v[:, None, None, None] * self.rhov)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = lam / (sigma_c[:, None, None, None] * np.sqrt(rho))
        return np.where(rho > 0, t, 0.0)

    def llr(self, d_pad: np.ndarray, beta_h: np.ndarray, beta_v: np.ndarray, sigma_c: np.ndarray,
            x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """(R, N) float64 LLR of particles at rows ``x``, columns ``y`` (R, N) with aspects ``z`` (R, N;
        0 absent) on the padded differential frames ``d_pad`` (R, ., .) with per-run beta_h, beta_v, sigma_c
        (R,). No checks: the caller holds the shapes (the inner loop of a filter). x, y and z are read in place, as
        the filter passes them (columns of its (R, N, 5) particles: strided views, no copy per frame), so the
        kernel is compiled for that layout; a C-contiguous one compiles a second version."""
        out = np.empty(x.shape)
        threads = numba.get_num_threads()
        numba.set_num_threads(threads if x.size >= PARALLEL_FROM else 1)
        try:
            _llr(d_pad, self.values, self.offsets, self.counts, np.array(self.half), self.rho0, self.rhoh,
                 self.rhov, beta_h, beta_v, sigma_c, x, y, z, out)
        finally:
            numba.set_num_threads(threads)
        return out


def detections(t: np.ndarray, half: tuple[int, int], pfa: float) -> np.ndarray:
    """Per-frame detections (n, 5) [run, row, column, aspect, t] of matched-filter statistics t (R, A, Le,
    Me): the positions (pixels; row = extended-grid index - hr) whose best aspect (1..A) passes Phi^-1(1 -
    pfa) and is the largest t of its 3 x 3 neighbourhood; FilterError for pfa outside (0, 1)."""
    if not 0 < pfa < 1:
        raise FilterError(f"detections: pfa must be in (0, 1), got {pfa}")
    best, aspect = t.max(axis=1), t.argmax(axis=1) + 1
    padded = np.pad(best, ((0, 0), (1, 1), (1, 1)), constant_values=-np.inf)
    Le, Me = best.shape[1:]
    peak = np.max([padded[:, 1 + du:1 + du + Le, 1 + dv:1 + dv + Me] for du in (-1, 0, 1) for dv in (-1, 0, 1)],
                  axis=0)
    r, i, j = np.nonzero((best >= ndtri(1.0 - pfa)) & (best >= peak))
    return np.column_stack([r, i - half[0], j - half[1], aspect[r, i, j], best[r, i, j]]).astype(float)
