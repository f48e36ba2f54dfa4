"""Heading-deviation profiles of Frencl (2014), Ch. 3: ``drop``, ``leaf`` and ``balloon``.

At every step a walker's heading changes by delta (rad), drawn from one of
three symmetric laws, each with one "objectivity" parameter (larger: a walker
holds its course more firmly):

* ``drop`` (parameter n > 1): density a / (2 (a |delta| + 1) ln n) on
  [-pi, pi] with a = (n - 1) / pi, heavy-shouldered even for large n;
* ``leaf`` (parameter lambda > 0): a Laplace law of rate lambda truncated to
  [-pi, pi];
* ``balloon`` (parameter sigma > 0, rad): a zero-mean Gaussian, not truncated
  (as the thesis draws it).

Each is sampled by its inverse CDF from uniforms, vectorised over any shape::

    prof = HeadingProfile("leaf", 7.0)
    delta = prof.sample(rng, (1000,))    # (1000,) rad
    prof.density(delta), prof.cdf(delta) # same shape, 1/rad and probability
    prof.variance()                      # rad^2, closed form (leaf 7: 0.0408)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.special import erfinv, ndtr

from nnda.errors import ConfigError

ProfileKind = Literal["drop", "leaf", "balloon"]
PROFILES: tuple[str, ...] = ("drop", "leaf", "balloon")


@dataclass(frozen=True)
class HeadingProfile:
    """One heading-deviation law: ``kind`` and its parameter (drop n > 1, leaf lambda > 0, balloon sigma rad > 0)."""

    kind: ProfileKind
    parameter: float

    def __post_init__(self) -> None:
        if self.kind not in PROFILES:
            raise ConfigError(f"heading profile: kind must be one of {', '.join(PROFILES)}, got {self.kind!r}")
        p = self.parameter
        low = 1.0 if self.kind == "drop" else 0.0
        if not (isinstance(p, (int, float)) and math.isfinite(p) and p > low):
            what = {"drop": "n", "leaf": "lambda", "balloon": "sigma"}[self.kind]
            raise ConfigError(f"heading profile {self.kind!r}: {what} must be a finite number > {low:g}, got {p!r}")

    # ------------------------------------------------------------------ the laws
    def _leaf_c(self) -> float:
        """Normalising constant c = 1 / (2 (1 - exp(-lambda pi))) of the truncated Laplace."""
        return 0.5 / -math.expm1(-self.parameter * math.pi)

    def quantile(self, u: np.ndarray) -> np.ndarray:
        """The inverse CDF: deviations (rad) for probabilities ``u`` in (0, 1), any shape."""
        u = np.asarray(u, dtype=float)
        p = float(self.parameter)
        if self.kind == "drop":
            s = np.sign(u - 0.5)
            return s * math.pi * np.expm1(np.abs(2.0 * u - 1.0) * math.log(p)) / (p - 1.0)
        if self.kind == "leaf":
            c, tail = self._leaf_c(), math.exp(-p * math.pi)
            lower = np.log(np.minimum(u, 0.5) / c + tail) / p
            upper = -np.log((np.minimum(1.0 - u, 0.5)) / c + tail) / p
            return np.where(u < 0.5, lower, upper)
        return math.sqrt(2.0) * p * erfinv(2.0 * u - 1.0)

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...]) -> np.ndarray:
        """``size`` deviations (rad) by the inverse CDF of uniforms drawn from ``rng``."""
        return self.quantile(rng.random(size))

    def density(self, delta: np.ndarray) -> np.ndarray:
        """Probability density (1/rad) at deviations ``delta`` (rad), any shape; 0 outside [-pi, pi] (drop, leaf)."""
        d = np.abs(np.asarray(delta, dtype=float))
        p = float(self.parameter)
        if self.kind == "balloon":
            return np.exp(-0.5 * (d / p) ** 2) / (p * math.sqrt(2.0 * math.pi))
        if self.kind == "drop":
            a = (p - 1.0) / math.pi
            f = a / (2.0 * (a * d + 1.0) * math.log(p))
        else:
            f = self._leaf_c() * p * np.exp(-p * d)
        return np.where(d <= math.pi, f, 0.0)

    def cdf(self, delta: np.ndarray) -> np.ndarray:
        """P(deviation <= delta) for ``delta`` (rad), any shape."""
        x = np.asarray(delta, dtype=float)
        p = float(self.parameter)
        if self.kind == "balloon":
            return ndtr(x / p)
        d = np.minimum(np.abs(x), math.pi)
        if self.kind == "drop":
            half = np.log1p((p - 1.0) / math.pi * d) / (2.0 * math.log(p))
        else:
            half = self._leaf_c() * -np.expm1(-p * d)
        return 0.5 + np.sign(x) * half

    def variance(self) -> float:
        """Closed-form variance of the deviation (rad^2); the mean is 0."""
        p = float(self.parameter)
        if self.kind == "balloon":
            return p * p
        if self.kind == "drop":  # E[d^2] = [(n^2 - 1)/2 - 2 (n - 1) + ln n] / (a^2 ln n), a = (n - 1)/pi
            a = (p - 1.0) / math.pi
            return ((p * p - 1.0) / 2.0 - 2.0 * (p - 1.0) + math.log(p)) / (a * a * math.log(p))
        e = math.exp(p * math.pi)  # the thesis's eq. 3.48
        return -(math.pi**2 * p * p + 2.0 * math.pi * p - 2.0 * e + 2.0) / (p * p * (e - 1.0))
