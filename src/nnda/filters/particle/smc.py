"""Particle filters over a state-space model (`nnda.filters.particle.ssm`), batched over R runs x N particles.

One call filters every run of a model (particles are arrays (R, N, d),
log-weights (R, N); no Python loop over runs or particles, one over steps):

    cfg = SMCConfig("optimal", n_particles=4000)      # or "bootstrap", "sis", "auxiliary", "resample-move"
    out = run_smc(model, cfg, seed=1)                  # seed: int or numpy Generator
    out.mean (R, K, e)   out.ess (R, K)   out.resampled (R, K)   out.log_evidence (R,)

Algorithms, step k (W the normalised weights of step k-1):

- ``bootstrap`` (SIR, Gordon-Salmond-Smith; Pavlov & Bruno 2003, eq. 23):
  x_k ~ p(x_k | x_k-1), w_k = W p(y_k | x_k). ``sis`` is the same step
  without any resampling (Bruno, Araújo & Pavlov, Sec. III-A;
  ``ess_threshold`` does not apply).
- ``optimal``: x_k ~ p(x_k | x_k-1, y_k), w_k = W p(y_k | x_k-1) (Pavlov &
  Bruno 2003, eqs. 16-22; the model's ``optimal_proposal``).
  ``resample_first`` resamples on these weights (which do not depend on
  x_k) before sampling, the other ordering (the paper does not say which
  it used); its estimate is the mean after sampling.
- ``auxiliary`` (Pitt & Shephard; Bruno, Araújo & Pavlov, Sec. III-B):
  first-stage weights lambda = p(y_k | mu^(j)) at a look-ahead point mu
  (``look_ahead``: "sample", a draw of the transition as Bruno, Araújo &
  Pavlov do; "mean", the transition mean; or
  "predictive", the exact p(y_k | x_k-1) when the model has an optimal
  proposal), ancestors drawn by lambda, fresh x_k ~ p(x_k | x_k-1^(i)),
  second-stage weights p(y_k | x_k) / p(y_k | mu^(i)). ``auxiliary_form``
  "paper" leaves W out of lambda and carries it in the weight (w = W^(i) p /
  p-hat); "standard" puts it into lambda (lambda = W p-hat). It resamples in
  its first stage at every step, so ``ess_threshold`` does not apply.
- ``resample-move`` (Gilks & Berzuini): a bootstrap step, resampling, then
  ``moves`` Metropolis-Hastings steps per particle on pi(x_k) ~ p(y_k |
  x_k) p(x_k | parent) with the parent kept, a Gaussian random walk whose
  covariance is ``move_scale``^2 times each run's empirical covariance of
  x_k - E[x_k | parent], or the model's own symmetric proposal ``move(k, x,
  rng)`` when it has one (a model with a discrete component, e.g. an
  aspect). Runs that did not resample at a step are not moved.

Resampling (`nnda.filters.particle.resampling`, by name) runs after the
weighting, at every step (``ess_threshold`` None, the paper) or in the runs
whose ESS = 1 / sum W^2 fell below ``ess_threshold`` N. The estimate of a
step is the weighted mean before resampling (``estimate`` "weighted") or the
mean after it ("resampled", the paper's post-selection mean); a model with
an ``estimate(W, x)`` method (R, e) gives its own summary in place of the
weighted mean (e.g. a presence probability and a conditional mean). ``ess``
records the ESS of each step's weights before resampling; ``log_evidence``
sums log p-hat(y_k | y_1:k-1). Particles are float64 or, with ``dtype``
"float32", float32 (log-weights stay float64). If every weight of a run is
zero (all log-weights -inf or NaN) the filter raises FilterError naming the
step and the runs instead of returning NaN.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from nnda.errors import FilterError
from nnda.filters.particle.resampling import resampler
from nnda.filters.particle.ssm import GaussianProposal, StateSpaceModel, right

#: the algorithms of `SMCConfig.algorithm`
ALGORITHMS = ("bootstrap", "sis", "optimal", "auxiliary", "resample-move")
#: added to the diagonal of the resample-move random walk's covariance (relative to its largest entry)
_JITTER = 1e-9


@dataclass(frozen=True)
class SMCConfig:
    """A particle filter: ``algorithm`` (one of ALGORITHMS), ``n_particles`` N >= 1 per run, the
    ``resampling`` scheme's name, ``ess_threshold`` (None: resample every step; a number in (0, 1]:
    when ESS < ess_threshold N), ``estimate``, the auxiliary filter's ``auxiliary_form`` and ``look_ahead``,
    the optimal filter's ``resample_first``, resample-move's ``moves`` (>= 1) and ``move_scale`` (> 0), and
    the particles' ``dtype``; see the module docstring. Checked on construction (FilterError)."""

    algorithm: str = "bootstrap"
    n_particles: int = 1000
    resampling: str = "multinomial"
    ess_threshold: float | None = None
    estimate: Literal["weighted", "resampled"] = "weighted"
    auxiliary_form: Literal["paper", "standard"] = "paper"
    look_ahead: Literal["sample", "mean", "predictive"] = "sample"
    resample_first: bool = False
    moves: int = 1
    move_scale: float = 1.0
    dtype: Literal["float64", "float32"] = "float64"

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise FilterError(f"SMCConfig.algorithm: unknown {self.algorithm!r}; choose one of {', '.join(ALGORITHMS)}")
        if not (isinstance(self.n_particles, int | np.integer) and self.n_particles >= 1):
            raise FilterError(f"SMCConfig.n_particles: must be an integer >= 1, got {self.n_particles!r}")
        resampler(self.resampling)
        if self.ess_threshold is not None and not 0 < self.ess_threshold <= 1:
            raise FilterError(f"SMCConfig.ess_threshold: must be in (0, 1] or None, got {self.ess_threshold}")
        choices = {"estimate": ("weighted", "resampled"), "auxiliary_form": ("paper", "standard"),
                   "look_ahead": ("sample", "mean", "predictive"), "dtype": ("float64", "float32")}
        for field, allowed in choices.items():
            if getattr(self, field) not in allowed:
                raise FilterError(f"SMCConfig.{field}: {getattr(self, field)!r} is not one of {', '.join(allowed)}")
        if not (isinstance(self.moves, int | np.integer) and self.moves >= 1):
            raise FilterError(f"SMCConfig.moves: must be an integer >= 1, got {self.moves!r}")
        if not (np.isfinite(self.move_scale) and self.move_scale > 0):
            raise FilterError(f"SMCConfig.move_scale: must be a finite number > 0, got {self.move_scale}")


@dataclass(frozen=True)
class SMCResult:
    """A filter's output over R runs and K steps: ``mean`` (R, K, e) the estimates (e = d, or the size of
    the model's ``estimate``), ``ess`` (R, K) the
    effective sample size before resampling, ``resampled`` (R, K) whether a run resampled, ``log_evidence``
    (R,) log p-hat(y_1:K), ``acceptance`` (R, K) resample-move's MH acceptance rate (NaN where a run did not
    move; None for the other algorithms)."""

    mean: np.ndarray
    ess: np.ndarray
    resampled: np.ndarray
    log_evidence: np.ndarray
    acceptance: np.ndarray | None


def normalise(logw: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(log W, log sum_i exp(logw_i)) per run of log-weights (R, N); FilterError naming step ``k`` and the
    runs whose weights are all zero or NaN."""
    top = logw.max(axis=1)
    bad = ~np.isfinite(top)
    if bad.any():
        runs = np.flatnonzero(bad)
        raise FilterError(f"step {k}: every particle weight of run(s) {runs[:10].tolist()} underflowed to zero "
                          f"or is NaN (log-weights -inf/NaN); the measurement may be far outside the particle cloud")
    logw = logw - top[:, None]
    total = np.log(np.exp(logw).sum(axis=1))
    logw -= total[:, None]
    return logw, top + total


def _mean(W: np.ndarray, x: np.ndarray) -> np.ndarray:
    """sum_i W_i x_i (R, d) in float64 for W (R, N), x (R, N, d)."""
    return (W.astype(x.dtype)[:, None, :] @ x)[:, 0, :].astype(np.float64)


def _take(x: np.ndarray, A: np.ndarray) -> np.ndarray:
    """x[r, A[r]] (R, M, ...) for ancestors A (R, M)."""
    R, N = x.shape[:2]
    flat = x.reshape(R * N, *x.shape[2:])
    return flat[A + (np.arange(R) * N)[:, None]]


class _Filter:
    """One run of `run_smc`: the particle system and the steps of each algorithm."""

    def __init__(self, model: StateSpaceModel, cfg: SMCConfig, rng: np.random.Generator) -> None:
        self.model, self.cfg, self.rng = model, cfg, rng
        self.resample = resampler(cfg.resampling)
        R, N, K = model.runs, cfg.n_particles, model.steps
        self.x = model.sample_initial(N, rng, np.dtype(cfg.dtype).type)
        self.logw = np.full((R, N), -np.log(N))
        self.mean: np.ndarray | None = None  # (R, K, e), allocated at the first estimate
        self.summary = getattr(model, "estimate", _mean)
        self.ess = np.empty((R, K))
        self.resampled = np.zeros((R, K), dtype=bool)
        self.log_evidence = np.zeros(R)
        self.acceptance = np.full((R, K), np.nan) if cfg.algorithm == "resample-move" else None

    def run(self) -> SMCResult:
        step = {"bootstrap": self.bootstrap, "sis": self.sis, "optimal": self.optimal, "auxiliary": self.auxiliary,
                "resample-move": self.resample_move}[self.cfg.algorithm]
        for k in range(1, self.model.steps + 1):
            step(k)
        return SMCResult(self.mean, self.ess, self.resampled, self.log_evidence, self.acceptance)

    def weigh(self, k: int, log_increment: np.ndarray) -> None:
        """Add the step's log-weight increments (R, N); normalise, record ESS and the evidence increment."""
        self.logw, log_sum = normalise(self.logw + log_increment, k)
        self.log_evidence += log_sum
        W = np.exp(self.logw)
        self.ess[:, k - 1] = 1.0 / np.einsum("rn,rn->r", W, W)

    def select(self, k: int, *carried: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Resample the runs that need it (every run, or ESS below the threshold): the particles and each
        array of ``carried`` (R, N, ...) reordered by the ancestors; returns the resampled runs' mask (R,)."""
        N = self.cfg.n_particles
        need = (np.ones(self.model.runs, dtype=bool) if self.cfg.ess_threshold is None
                else self.ess[:, k - 1] < self.cfg.ess_threshold * N)
        self.resampled[:, k - 1] = need
        carried = list(carried)
        if need.all():
            A = self.resample(np.exp(self.logw), N, self.rng)
            self.x = _take(self.x, A)
            carried = [_take(c, A) for c in carried]
            self.logw = np.full_like(self.logw, -np.log(N))
        elif need.any():
            rows = np.flatnonzero(need)
            A = self.resample(np.exp(self.logw[rows]), N, self.rng)
            self.x[rows] = _take(self.x[rows], A)
            for c in carried:
                c[rows] = _take(c[rows], A)
            self.logw[rows] = -np.log(N)
        return need, carried

    def estimate(self, k: int) -> None:
        est = self.summary(np.exp(self.logw), self.x)
        if self.mean is None:
            self.mean = np.empty((self.model.runs, self.model.steps, est.shape[-1]))
        self.mean[:, k - 1] = est

    def bootstrap(self, k: int) -> None:
        self.x = self.model.sample_transition(k, self.x, self.rng)
        self.weigh(k, self.model.log_likelihood(k, self.x))
        self._estimate_and_select(k)

    def sis(self, k: int) -> None:
        self.x = self.model.sample_transition(k, self.x, self.rng)
        self.weigh(k, self.model.log_likelihood(k, self.x))
        self.estimate(k)

    def _estimate_and_select(self, k: int) -> None:
        if self.cfg.estimate == "weighted":
            self.estimate(k)
        self.select(k)
        if self.cfg.estimate == "resampled":
            self.estimate(k)

    def _draw(self, mean: np.ndarray, chol: np.ndarray) -> np.ndarray:
        """mean + L e, e ~ N(0, I): mean (R, N, d), chol (R, d, d)."""
        noise = self.rng.standard_normal(mean.shape, dtype=mean.dtype)
        return mean + noise @ right(chol.swapaxes(-1, -2), mean.dtype)

    def optimal(self, k: int) -> None:
        prop = self._proposal(k)
        self.weigh(k, prop.log_predictive)
        if self.cfg.resample_first:
            self.x = prop.mean
            self.select(k)
            self.x = self._draw(self.x, prop.chol)
            self.estimate(k)
        else:
            self.x = self._draw(prop.mean, prop.chol)
            self._estimate_and_select(k)

    def _proposal(self, k: int) -> GaussianProposal:
        proposal = getattr(self.model, "optimal_proposal", None)
        if proposal is None:
            raise FilterError(f"{self.cfg.algorithm}: the model {type(self.model).__name__} has no optimal proposal")
        return proposal(k, self.x)

    def auxiliary(self, k: int) -> None:
        model, N = self.model, self.cfg.n_particles
        if self.cfg.look_ahead == "predictive":
            ll_hat = self._proposal(k).log_predictive
        else:
            mu = (model.sample_transition(k, self.x, self.rng) if self.cfg.look_ahead == "sample"
                  else model.transition_mean(k, self.x))
            ll_hat = model.log_likelihood(k, mu)
        paper = self.cfg.auxiliary_form == "paper"
        log_lam, log_sum = normalise(ll_hat if paper else self.logw + ll_hat, k)
        A = self.resample(np.exp(log_lam), N, self.rng)
        self.resampled[:, k - 1] = True
        self.x = model.sample_transition(k, _take(self.x, A), self.rng)
        second = model.log_likelihood(k, self.x) - np.take_along_axis(ll_hat, A, axis=1)
        if paper:
            second += np.take_along_axis(self.logw, A, axis=1)
        # log p-hat(y_k | y_1:k-1) = log sum lambda + log mean of the second-stage weights (W normalised)
        self.log_evidence += log_sum - np.log(N)
        self.logw = np.zeros_like(self.logw)
        self.weigh(k, second)
        self.estimate(k)

    def resample_move(self, k: int) -> None:
        model, cfg = self.model, self.cfg
        parent = self.x
        self.x = model.sample_transition(k, parent, self.rng)
        ll = model.log_likelihood(k, self.x)
        self.weigh(k, ll)
        if cfg.estimate == "weighted":
            self.estimate(k)
        moved, (parent, ll) = self.select(k, parent, ll)  # the likelihoods follow their particles
        propose = getattr(model, "move", None)
        if propose is None:
            # the random walk's covariance: each run's spread of x_k about E[x_k | parent], scaled
            d = self.x - model.transition_mean(k, parent)
            C = np.einsum("rni,rnj->rij", d, d, dtype=np.float64) / d.shape[1]
            C += (_JITTER * np.abs(C).max(axis=(1, 2), keepdims=True) + np.finfo(float).tiny) * np.eye(C.shape[-1])
            L = cfg.move_scale * np.linalg.cholesky(C)
        log_pi = ll + model.transition_log_density(k, parent, self.x)
        accepted = np.zeros(self.x.shape[:2])
        for _ in range(cfg.moves):
            proposal = self._draw(self.x, L) if propose is None else propose(k, self.x, self.rng)
            log_pi_new = model.log_likelihood(k, proposal) + model.transition_log_density(k, parent, proposal)
            accept = (np.log(self.rng.random(log_pi.shape)) < log_pi_new - log_pi) & moved[:, None]
            self.x = np.where(accept[..., None], proposal, self.x)
            log_pi = np.where(accept, log_pi_new, log_pi)
            accepted += accept
        self.acceptance[moved, k - 1] = accepted[moved].mean(axis=1) / cfg.moves
        if cfg.estimate == "resampled":
            self.estimate(k)


def run_smc(model: StateSpaceModel, config: SMCConfig, seed: int | np.random.Generator) -> SMCResult:
    """Filter every run of ``model`` with ``config``; every draw from one Generator (``seed`` or a Generator)."""
    return _Filter(model, config, np.random.default_rng(seed)).run()
