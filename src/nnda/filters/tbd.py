"""Track-before-detect in image frames (Bruno, Araújo & Pavlov): the mixed-state model on the SMC engine and
the filters over it, batched over R runs x N particles.

    model = tbd_model(fs, TBDConfig())                 # fs: a nnda.data.frames.FrameSet (R runs of K frames)
    out = run_tbd(model, "apf", 5000, seed=1)          # or "apf-standard", "rs", "sis", "bootstrap"
    out.p_absent (R, K)   out.present (R, K)   out.position (R, K, 2)   out.evaluations_per_frame

The state of a particle is [x, vx, y, vy, z] (pixels, pixels per time
unit; z the aspect, 0 = absent, stored as a float). `TBDModel` implements
`nnda.filters.particle.ssm.StateSpaceModel` with the frames' own model
(`nnda.data.frames`: NCV motion, eq. (1) with G and p_entry, birth f_0):

- transition: s_n = F s_n-1 + u_n for every particle (u_n of the frames'
  q, or of the filter's own ``q`` when set: a larger q lets a particle's
  velocity move, where the frames' q = 6 pixels^2 per time unit^3 moves it
  by sqrt(q dt) = 0.49 pixels per time unit a frame, so a cloud that has
  collapsed onto one wrong velocity drifts off the target); a present particle
  whose new centroid is off the extended grid becomes absent, otherwise
  its aspect moves by G ("consistent" ``aspect_draw``), or, as the paper,
  z_n is drawn from eq. (1) with P_in the Gaussian probability that the
  predicted centroid quantises onto the extended grid, independently of
  s_n ("paper"); an absent particle enters with probability p_entry, with
  a uniform aspect and s_n from f_0;
- likelihood: the LLR of `nnda.filters.frame_likelihood` on the frame
  less its known background, with the GMRF parameters known (the frames'
  config) or estimated per frame and run (``gmrf`` "estimated",
  `nnda.data.gmrf.estimate`); the LLR differs from log p(y | s, z) by
  log p(y | absent), the same for every particle of a run, so weights are
  exact and ``log_evidence`` is the log of p(y_1:K) / p(y_1:K | absent);
- the resample-move proposal (`move`): a Gaussian random walk on position
  (``move_position_sd`` pixels) and velocity (``move_velocity_sd``) and, for
  a present particle with probability ``move_aspect``, a uniform redraw of
  its aspect among 1..A; symmetric, so the engine accepts with min(1,
  pi' / pi), pi = p(y_n | s_n, z_n) p(s_n, z_n | parent), the parent kept;
- the summary (`estimate`): [P(z_n = 0), E[x, vx, y, vy | z_n != 0]] from
  the weights; the target is declared present when P(z_n = 0) < 0.5 (the
  minimum-error test, the paper's eq. 17).

The filters: ``apf`` the auxiliary filter of the paper (first-stage
weights from a sampled look-ahead, W carried in the second stage),
``apf-standard`` (W in the first stage), ``rs`` resample-move (bootstrap
step, resampling, ``moves`` MH moves), ``sis`` (no resampling) and
``bootstrap`` (SIR). The filter's prior: the target present with
probability ``prior_present`` (uniform aspect, s from f_0), else absent.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.special import ndtr

from nnda.data import gmrf
from nnda.data.frames import FramesConfig, FrameSet, aspect_matrix, ncv_matrices, on_extended_grid, sample_birth
from nnda.errors import FilterError
from nnda.filters.frame_likelihood import FrameLikelihood
from nnda.filters.particle.smc import SMCConfig, run_smc
from nnda.filters.particle.ssm import LOG_2PI, gaussian_log_density, right
from nnda.validation import check_array, check_finite

#: the filters of `run_tbd` and their engine settings (`nnda.filters.particle.smc`)
FILTERS = {
    "apf": {"algorithm": "auxiliary", "auxiliary_form": "paper", "look_ahead": "sample"},
    "apf-standard": {"algorithm": "auxiliary", "auxiliary_form": "standard", "look_ahead": "sample"},
    "rs": {"algorithm": "resample-move"},
    "sis": {"algorithm": "sis"},
    "bootstrap": {"algorithm": "bootstrap"},
}
#: a target is declared present when P(z = 0) is below this (eq. 17)
PRESENT_BELOW = 0.5

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class TBDConfig(BaseModel):
    """The filter side of track-before-detect (module docstring): ``gmrf`` known or estimated per frame,
    ``aspect_draw``, ``q`` the filter's acceleration-noise intensity (pixels^2 per time unit^3; None: the frames'
    own), ``prior_present``, the resample-move proposal's ``move_position_sd`` (pixels),
    ``move_velocity_sd`` (pixels per time unit) and ``move_aspect``, resample-move's ``moves`` and the
    ``resampling`` scheme."""

    model_config = _STRICT

    gmrf: Literal["known", "estimated"] = "known"
    aspect_draw: Literal["consistent", "paper"] = "consistent"
    q: float | None = Field(None, gt=0)
    prior_present: float = Field(0.5, ge=0, le=1)
    move_position_sd: float = Field(0.5, gt=0)
    move_velocity_sd: float = Field(1.0, ge=0)
    move_aspect: float = Field(0.5, ge=0, le=1)
    moves: int = Field(1, ge=1)
    resampling: str = "multinomial"


class TBDModel:
    """The mixed-state model of R runs of K frames (module docstring).

    ``frames`` (R, K, L, M) raw frames, ``templates`` (A, 2h+1, 2h+1) at
    their amplitude, ``model`` the frames' model (shape, motion, G,
    p_entry, f_0, and the known GMRF parameters), ``background`` (L, M) the
    known local means (None: zero). FilterError for frames of mixed sizes
    or another size than the model's, NaN pixels, a template larger than
    the frame. ``evaluations`` counts the particle likelihoods computed; a list in ``snapshots`` collects
    (W, x) of every step's estimate (copies; for a figure of the particles).
    """

    dim = 5

    def __init__(self, frames: np.ndarray, templates: np.ndarray, model: FramesConfig, cfg: TBDConfig,
                 background: np.ndarray | None = None) -> None:
        frames = _frames_array(frames, model.shape)
        check_finite("TBDModel.frames (run, frame, row, column)", frames, error=FilterError)
        if background is not None:
            background = check_array("TBDModel.background", background, model.shape, error=FilterError)
            check_finite("TBDModel.background", background, error=FilterError)
            frames = frames - background
        self.frames, self.model, self.cfg = frames, model, cfg
        self.likelihood = FrameLikelihood(templates, model.shape)
        if self.likelihood.half != (model.template_half,) * 2:
            raise FilterError(f"TBDModel.templates: shape {templates.shape[1:]} is not the model's "
                              f"{2 * model.template_half + 1} x {2 * model.template_half + 1} support")
        self.n_aspects = self.likelihood.n_aspects
        self.G = aspect_matrix(self.n_aspects, model.aspect_stay)
        #: the filter's acceleration-noise intensity: its own, else the frames'
        self.q = model.q if cfg.q is None else cfg.q
        self.F, self.LQ = ncv_matrices(model.dt, self.q)
        if self.q <= 0 or model.birth_velocity_sd <= 0:
            raise FilterError("TBDModel: q and birth_velocity_sd must be > 0 (the transition needs a density)")
        Q = self.LQ @ self.LQ.T
        self._Q_inv_t = np.linalg.inv(self.LQ).T
        self._log_det_Q = float(np.linalg.slogdet(Q)[1])
        h = model.template_half
        self._birth_log_area = float(np.log((model.rows - 1 - 2 * h) * (model.cols - 1 - 2 * h)))
        self._frame_k = 0
        self.evaluations = 0
        self.snapshots: list[tuple[np.ndarray, np.ndarray]] | None = None
        self.runs, self.steps = frames.shape[:2]

    # -- what the engine calls -------------------------------------------------------------------------------
    def sample_initial(self, n: int, rng: np.random.Generator, dtype: type = np.float64) -> np.ndarray:
        """(R, n, 5): present with probability prior_present (s from f_0, uniform aspect), else absent."""
        x = np.empty((self.runs, n, 5), dtype=dtype)
        x[..., :4] = sample_birth(self.model, rng, (self.runs, n))
        present = rng.random((self.runs, n)) < self.cfg.prior_present
        x[..., 4] = np.where(present, rng.integers(1, self.n_aspects + 1, (self.runs, n)), 0)
        return x

    def transition_mean(self, k: int, x: np.ndarray) -> np.ndarray:
        """(R, N, 5): F s with the aspect kept."""
        out = x.copy()
        out[..., :4] = x[..., :4] @ right(self.F.T, x.dtype)
        return out

    def sample_transition(self, k: int, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        R, N = x.shape[:2]
        out = np.empty_like(x)
        s = x[..., :4] @ right(self.F.T, x.dtype)
        s += rng.standard_normal((R, N, 4), dtype=x.dtype) @ right(self.LQ.T, x.dtype)
        z = x[..., 4]
        present = z > 0
        if self.cfg.aspect_draw == "paper":
            stays = rng.random((R, N)) < self._p_in(x)
        else:
            stays = on_extended_grid(s[..., 0], s[..., 2], self.model.shape, self.model.template_half)
        cum = np.cumsum(self.G, axis=0).T[np.maximum(z, 1).astype(np.int64) - 1]  # (R, N, A) of the old aspect
        moved = np.minimum((rng.random((R, N))[..., None] >= cum).sum(axis=-1), self.n_aspects - 1) + 1
        enter = ~present & (rng.random((R, N)) < self.model.p_entry)
        born = rng.integers(1, self.n_aspects + 1, (R, N))
        out[..., 4] = np.where(present, np.where(stays, moved, 0), np.where(enter, born, 0))
        if enter.any():
            s[enter] = sample_birth(self.model, rng, (int(enter.sum()),))
        out[..., :4] = s
        return out

    def transition_log_density(self, k: int, x_prev: np.ndarray, x: np.ndarray) -> np.ndarray:
        """log p(s_n, z_n | s_n-1, z_n-1) (R, N), -inf where impossible."""
        z_prev, z = x_prev[..., 4], x[..., 4]
        s = x[..., :4]
        log_fs = gaussian_log_density(s - x_prev[..., :4] @ right(self.F.T, s.dtype), self._Q_inv_t, self._log_det_Q)
        zi, zpi = z.astype(np.int64), z_prev.astype(np.int64)
        with np.errstate(divide="ignore"):
            log_G = np.log(self.G)[np.maximum(zi, 1) - 1, np.maximum(zpi, 1) - 1]
            if self.cfg.aspect_draw == "paper":
                p_in = self._p_in(x_prev)
                from_present = np.where(zi > 0, np.log(p_in) + log_G, np.log1p(-p_in)) + log_fs
            else:
                inside = on_extended_grid(s[..., 0], s[..., 2], self.model.shape, self.model.template_half)
                from_present = np.where((zi > 0) == inside, np.where(zi > 0, log_G, 0.0) + log_fs, -np.inf)
            pe = self.model.p_entry
            from_absent = np.where(zi > 0, np.log(pe / self.n_aspects) + self._birth_log_density(s),
                                   np.log1p(-pe) + log_fs)
        return np.where(zpi > 0, from_present, from_absent)

    def log_likelihood(self, k: int, x: np.ndarray) -> np.ndarray:
        """The frame LLR (R, N) of frame k at the particles."""
        d_pad, bh, bv, sc = self.frame_data(k)
        self.evaluations += x.shape[0] * x.shape[1]
        return self.likelihood.llr(d_pad, bh, bv, sc, x[..., 0], x[..., 2], x[..., 4])

    def move(self, k: int, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The symmetric MH proposal (module docstring)."""
        R, N = x.shape[:2]
        out = x.copy()
        sd = np.array([self.cfg.move_position_sd, self.cfg.move_velocity_sd] * 2, dtype=x.dtype)
        out[..., :4] += rng.standard_normal((R, N, 4), dtype=x.dtype) * sd
        redraw = (x[..., 4] > 0) & (rng.random((R, N)) < self.cfg.move_aspect)
        out[..., 4] = np.where(redraw, rng.integers(1, self.n_aspects + 1, (R, N)), x[..., 4])
        return out

    def estimate(self, W: np.ndarray, x: np.ndarray) -> np.ndarray:
        """(R, 5): [P(z = 0), E[x, vx, y, vy | z != 0]] (the weighted mean of all particles where no
        present particle has weight)."""
        if self.snapshots is not None:
            self.snapshots.append((W.copy(), x.copy()))
        Wp = W * (x[..., 4] > 0)
        mass = Wp.sum(axis=1)
        none = mass <= 0
        Wp[none] = W[none]
        mean = np.einsum("rn,rnd->rd", Wp, x[..., :4].astype(np.float64)) / Wp.sum(axis=1)[:, None]
        return np.concatenate([1.0 - mass[:, None], mean], axis=1)

    # -- helpers -------------------------------------------------------------------------------------------
    def frame_data(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(d padded (R, ., .), beta_h, beta_v, sigma_c (R,)) of frame k, kept for the step's repeated calls."""
        if self._frame_k != k:
            Y = np.asarray(self.frames[:, k - 1], dtype=np.float64)
            R = Y.shape[0]
            if self.cfg.gmrf == "estimated":
                bh, bv, sc = gmrf.estimate(Y)
            else:
                m = self.model
                bh, bv, sc = np.full(R, m.beta_h), np.full(R, m.beta_v), np.full(R, m.sigma_c)
            self._data = (self.likelihood.pad(gmrf.differential(Y, bh, bv)), bh, bv, sc)
            self._frame_k = k
        return self._data

    def _p_in(self, x: np.ndarray) -> np.ndarray:
        """P_in (R, N): the probability that the centroid predicted from x quantises onto the extended grid
        (eq. 6; independent Gaussian positions of variance q dt^3 / 3 about x + dt v, the filter's q)."""
        m, h = self.model, self.model.template_half
        sd = np.sqrt(self.q * m.dt**3 / 3.0)
        p = np.ones(x.shape[:2])
        for pos, size in ((0, m.rows), (2, m.cols)):
            mu = x[..., pos] + m.dt * x[..., pos + 1]
            p *= ndtr((size - 0.5 + h - mu) / sd) - ndtr((-h - 0.5 - mu) / sd)
        return p

    def _birth_log_density(self, s: np.ndarray) -> np.ndarray:
        """log f_0(s) (R, N): uniform centroid over the birth region, N(0, sd^2) velocities."""
        m, h = self.model, self.model.template_half
        inside = (s[..., 0] >= h) & (s[..., 0] <= m.rows - 1 - h) & (s[..., 2] >= h) & (s[..., 2] <= m.cols - 1 - h)
        v2 = (s[..., 1] ** 2 + s[..., 3] ** 2) / m.birth_velocity_sd**2
        log_v = -0.5 * v2 - LOG_2PI - 2.0 * np.log(m.birth_velocity_sd)
        return np.where(inside, log_v - self._birth_log_area, -np.inf)


def _frames_array(frames: object, shape: tuple[int, int]) -> np.ndarray:
    """Frames (R, K, L, M) as an array (a memory map stays one); FilterError naming the first frame of
    another size for a nested sequence of frames of mixed sizes, or frames of another size than ``shape``."""
    if not isinstance(frames, np.ndarray):
        flat = [(r, k, np.shape(f)) for r, run in enumerate(frames) for k, f in enumerate(run)]
        odd = next(((r, k, s) for r, k, s in flat if s != flat[0][2]), None)
        if odd is not None:
            raise FilterError(f"TBDModel.frames: frames of mixed sizes: run {odd[0]} frame {odd[1]} is "
                              f"{odd[2]}, run 0 frame 0 is {flat[0][2]}")
        frames = np.asarray(frames, dtype=np.float64)
    if frames.ndim != 4 or frames.shape[2:] != shape or 0 in frames.shape[:2]:
        raise FilterError(f"TBDModel.frames: expected (runs, frames, {shape[0]}, {shape[1]}) with at least one "
                          f"run and frame, got {frames.shape}")
    return frames


def tbd_model(fs: FrameSet, cfg: TBDConfig, model: FramesConfig | None = None) -> TBDModel:
    """The model of a frame set: its frames, templates and background, and its own config as the filter's
    model (or ``model``, a mismatched one)."""
    return TBDModel(fs.frames, fs.templates, model or fs.config, cfg, fs.background)


@dataclass(frozen=True)
class TBDResult:
    """A filter's output over R runs of K frames: ``p_absent`` (R, K) P(z = 0), ``present`` (R, K) the
    decision P(z = 0) < 0.5, ``position`` (R, K, 2) and ``velocity`` (R, K, 2) the conditional means given
    present, ``ess`` (R, K), ``evaluations_per_frame`` (particle likelihoods per run and frame) and
    ``seconds``."""

    p_absent: np.ndarray
    present: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    ess: np.ndarray
    evaluations_per_frame: float
    seconds: float


def smc_config(name: str, n: int, cfg: TBDConfig) -> SMCConfig:
    """The engine's config of filter ``name`` (FILTERS) at ``n`` particles."""
    if name not in FILTERS:
        raise FilterError(f"unknown TBD filter {name!r}; choose one of {', '.join(FILTERS)}")
    return SMCConfig(n_particles=n, resampling=cfg.resampling, moves=cfg.moves, **FILTERS[name])


def run_tbd(model: TBDModel, name: str, n: int, seed: int | np.random.Generator) -> TBDResult:
    """Filter every run of ``model`` with filter ``name`` at ``n`` particles per run."""
    smc = smc_config(name, n, model.cfg)
    before = model.evaluations
    t0 = time.perf_counter()
    out = run_smc(model, smc, seed)
    seconds = time.perf_counter() - t0
    est = out.mean
    p_absent = est[..., 0]
    per_frame = (model.evaluations - before) / (model.runs * model.steps)
    return TBDResult(p_absent, p_absent < PRESENT_BELOW, est[..., [1, 3]], est[..., [2, 4]], out.ess, per_frame,
                     seconds)
