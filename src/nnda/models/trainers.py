"""Training the association network: full-batch gradient descent and Levenberg-Marquardt.

Both minimise the mean squared error over the training subset,
stop early when the validation error has not improved for ``max_fail``
epochs in a row (MATLAB's validation check: an epoch that
ties the best does not count as a failure), and return the weights of the
epoch with the lowest validation error. Without a validation subset they
run until another criterion stops them and return the last weights.

Levenberg-Marquardt (Vargas Avila (2015), eq. 3.10): per epoch the Jacobian J (P, K) of
the training residuals e = output - target with respect to all K weights
(torch.func: reverse-mode gradient of one pair's residual, vmapped over the
P pairs; faster here than forward mode over the K weights), then steps
dw = -(J^T J + mu I)^-1 J^T e with mu raised by ``beta`` until the error
falls (step accepted, mu lowered by ``beta``) or mu exceeds ``mu_max``
(training stops). The training error therefore falls strictly from one
epoch to the next.

Stop reasons: ``"max_epochs"``, ``"validation"``, ``"min_grad"`` (norm of
the MSE gradient below ``min_grad``), ``"mu_max"``.

Both run torch on one thread (restored afterwards): the tensors are a few
thousand pairs by a few dozen weights, and torch's intra-op threads only
add synchronisation; on a busy 2-core machine they made an LM fit 15-50x
slower (0.13 s on one thread against 2-6 s on two, measured).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from nnda.errors import ModelError
from nnda.models.network import DTYPE, as_tensor, forward, mse, torch

grad, jacrev, vmap = torch.func.grad, torch.func.jacrev, torch.func.vmap

EpochCallback = Callable[[int, dict[str, float]], None]


@dataclass(frozen=True)
class Subset:
    """Normalised inputs ``x`` (P, N) and targets ``y`` (P,) in {-1, +1}."""

    x: np.ndarray
    y: np.ndarray


@dataclass(frozen=True)
class GDSettings:
    """Gradient descent (MATLAB ``traingd`` defaults where the thesis gives no value).

    ``min_grad`` is traingd's default 1e-5; the thesis gives none for GD.
    """

    lr: float = 0.01
    max_epochs: int = 1000
    max_fail: int = 6
    min_grad: float = 1e-5


@dataclass(frozen=True)
class LMSettings:
    """Levenberg-Marquardt (mu and beta from Vargas Avila (2015)); ``mu_min`` (ours) keeps mu from underflowing to 0."""

    mu: float = 0.01
    beta: float = 10.0
    mu_max: float = 1e10
    mu_min: float = 1e-20
    max_epochs: int = 1000
    max_fail: int = 6
    min_grad: float = 1e-7


@dataclass(frozen=True)
class TrainingResult:
    """Outcome of one training run.

    ``theta`` (K,) the returned weights; ``loss`` maps each subset given
    (train, validation, test) to its MSE per epoch, shape (epochs + 1,),
    entry 0 for the initial weights; ``mu`` (epochs + 1,) LM's damping
    after each epoch (empty for GD); ``epochs`` weight updates performed;
    ``best_epoch`` the epoch whose weights are returned; ``seconds`` wall time.
    """

    method: str
    theta: np.ndarray
    loss: dict[str, np.ndarray]
    mu: np.ndarray
    epochs: int
    best_epoch: int
    stop_reason: str
    seconds: float


@dataclass
class _Log:
    """Per-epoch bookkeeping shared by both trainers: losses, validation check, best weights."""

    subsets: dict[str, tuple[torch.Tensor, torch.Tensor]]
    n_hidden: int
    max_fail: int
    on_epoch: EpochCallback | None
    loss: dict[str, list[float]] = field(default_factory=dict)
    best: tuple[float, torch.Tensor, int] | None = None
    fails: int = 0

    def record(self, epoch: int, theta: torch.Tensor) -> bool:
        """Log the losses of ``theta`` after ``epoch``; True when validation says stop."""
        losses = {name: float(mse(theta, x, y, self.n_hidden)) for name, (x, y) in self.subsets.items()}
        for name, value in losses.items():
            self.loss.setdefault(name, []).append(value)
        if self.on_epoch is not None:
            self.on_epoch(epoch, losses)
        key = losses.get("validation")
        if self.best is None or key is None or key < self.best[0]:
            self.best = (np.inf if key is None else key, theta.clone(), epoch)
            self.fails = 0
        elif key > self.best[0]:
            self.fails += 1
        return self.fails >= self.max_fail

    def result(self, method: str, epochs: int, reason: str, seconds: float, mu: list[float]) -> TrainingResult:
        _, theta, best_epoch = self.best
        return TrainingResult(method, theta.numpy().copy(), {k: np.array(v) for k, v in self.loss.items()},
                              np.array(mu), epochs, best_epoch, reason, seconds)


def _subsets(train: Subset, validation: Subset | None, test: Subset | None) -> dict:
    out = {}
    for name, s in (("train", train), ("validation", validation), ("test", test)):
        if s is None:
            continue
        x, y = np.asarray(s.x, dtype=float), np.asarray(s.y, dtype=float)
        if x.ndim != 2 or y.shape != (len(x),) or len(x) == 0:
            raise ModelError(f"{name} subset: need x (P, N) and y (P,) with P >= 1, got {x.shape} and {y.shape}")
        if not (np.isfinite(x).all() and np.isfinite(y).all()):
            raise ModelError(f"{name} subset: inputs or targets hold non-finite values")
        out[name] = (as_tensor(x), as_tensor(y))
    return out


def _one_thread(trainer):
    @functools.wraps(trainer)
    def wrapped(*args, **kwargs):
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            return trainer(*args, **kwargs)
        finally:
            torch.set_num_threads(threads)
    return wrapped


@_one_thread
def train_gd(
    theta0: np.ndarray, n_hidden: int, train: Subset, validation: Subset | None = None,
    test: Subset | None = None, settings: GDSettings = GDSettings(), on_epoch: EpochCallback | None = None,
) -> TrainingResult:
    """Full-batch gradient descent on the training MSE, no momentum: w <- w - lr dMSE/dw."""
    subsets = _subsets(train, validation, test)
    x, y = subsets["train"]
    log = _Log(subsets, n_hidden, settings.max_fail, on_epoch)
    gradient = grad(lambda th: mse(th, x, y, n_hidden))
    start = time.perf_counter()
    theta = as_tensor(theta0)
    log.record(0, theta)
    reason, epoch = "max_epochs", 0
    for epoch in range(1, settings.max_epochs + 1):
        g = gradient(theta)
        if float(torch.linalg.vector_norm(g)) < settings.min_grad:
            reason, epoch = "min_grad", epoch - 1
            break
        theta = theta - settings.lr * g
        if log.record(epoch, theta):
            reason = "validation"
            break
    return log.result("gd", epoch, reason, time.perf_counter() - start, [])


@_one_thread
def train_lm(
    theta0: np.ndarray, n_hidden: int, train: Subset, validation: Subset | None = None,
    test: Subset | None = None, settings: LMSettings = LMSettings(), on_epoch: EpochCallback | None = None,
) -> TrainingResult:
    """Levenberg-Marquardt on the training residuals (module docstring)."""
    subsets = _subsets(train, validation, test)
    x, y = subsets["train"]
    log = _Log(subsets, n_hidden, settings.max_fail, on_epoch)

    def residuals(th: torch.Tensor) -> torch.Tensor:
        return forward(th, x, n_hidden) - y

    def residual(th: torch.Tensor, xi: torch.Tensor, yi: torch.Tensor) -> torch.Tensor:
        return forward(th, xi[None, :], n_hidden)[0] - yi

    jacobian = vmap(jacrev(residual), in_dims=(None, 0, 0))  # (P, K)
    start = time.perf_counter()
    theta = as_tensor(theta0)
    eye = torch.eye(len(theta), dtype=DTYPE)
    e = residuals(theta)
    sse = float(e @ e)
    mu, mus = settings.mu, [settings.mu]
    log.record(0, theta)
    reason, epoch = "max_epochs", 0
    for epoch in range(1, settings.max_epochs + 1):
        jac = jacobian(theta, x, y)
        je = jac.T @ e
        if 2.0 * float(torch.linalg.vector_norm(je)) / len(y) < settings.min_grad:
            reason, epoch = "min_grad", epoch - 1
            break
        jj = jac.T @ jac
        while mu <= settings.mu_max:
            step, info = torch.linalg.solve_ex(jj + mu * eye, -je)
            trial = theta + step
            e_trial = residuals(trial)
            sse_trial = float(e_trial @ e_trial)
            if int(info) == 0 and sse_trial < sse:
                theta, e, sse = trial, e_trial, sse_trial
                mu = max(mu / settings.beta, settings.mu_min)
                break
            mu *= settings.beta
        if mu > settings.mu_max:
            reason, epoch = "mu_max", epoch - 1
            break
        mus.append(mu)
        if log.record(epoch, theta):
            reason = "validation"
            break
    return log.result("lm", epoch, reason, time.perf_counter() - start, mus)
