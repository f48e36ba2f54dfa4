"""The N-H-1 tanh network in plain numpy: weights, their flat layout and initialisation.

This module imports no torch: the tracker scores pairs with it, and the
trainers (`nnda.models.trainers`) share its weight layout.

Flat weight vector (Vargas Avila (2015), eq. 3.18), length K = H (N + 1) + H + 1: layer by
layer, and within a layer neuron by neuron with the bias first, i.e.
``[b1_0, w1_00 .. w1_0(N-1), b1_1, w1_10, .., b2, w2_0 .. w2_(H-1)]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


def n_weights(n_inputs: int, n_hidden: int) -> int:
    """Length K of the flat weight vector of an N-H-1 network."""
    return n_hidden * (n_inputs + 1) + n_hidden + 1


def unpack(theta: Any, n_inputs: int, n_hidden: int) -> tuple[Any, Any, Any, Any]:
    """Views (w1 (H, N), b1 (H,), w2 (H,), b2 ()) into a flat weight vector.

    Uses only slicing and reshape, so it serves numpy arrays and torch tensors alike.
    """
    split = n_hidden * (n_inputs + 1)
    hidden = theta[:split].reshape(n_hidden, n_inputs + 1)
    return hidden[:, 1:], hidden[:, 0], theta[split + 1:], theta[split]


@dataclass(frozen=True)
class MLPWeights:
    """Weights of an N-H-1 network with tanh hidden and output units.

    ``w1`` (H, N), ``b1`` (H,), ``w2`` (H,), ``b2`` float; output
    tanh(w2 . tanh(w1 x + b1) + b2) in (-1, 1) for a normalised input x (N,).
    """

    w1: np.ndarray
    b1: np.ndarray
    w2: np.ndarray
    b2: float

    @property
    def n_inputs(self) -> int:
        return self.w1.shape[1]

    @property
    def n_hidden(self) -> int:
        return self.w1.shape[0]

    @classmethod
    def from_vector(cls, theta: np.ndarray, n_inputs: int, n_hidden: int) -> MLPWeights:
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (n_weights(n_inputs, n_hidden),):
            raise ValueError(f"a {n_inputs}-{n_hidden}-1 network has {n_weights(n_inputs, n_hidden)} "
                             f"weights, got shape {theta.shape}")
        w1, b1, w2, b2 = unpack(theta.copy(), n_inputs, n_hidden)
        return cls(w1, b1, w2, float(b2))

    def to_vector(self) -> np.ndarray:
        """The flat layout described in the module docstring, shape (K,)."""
        hidden = np.column_stack([self.b1, self.w1]).ravel()
        return np.concatenate([hidden, [self.b2], self.w2])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Outputs (P,) for normalised inputs ``x`` (P, N)."""
        # (H, N) @ (N, P) keeps BLAS single-threaded on tall inputs, where threads only add overhead
        return np.tanh(np.tanh((self.w1 @ x.T).T + self.b1) @ self.w2 + self.b2)


def _nguyen_widrow_layer(
    input_range: np.ndarray, n_out: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Weights (n_out, n_in) and biases (n_out,) of one tanh layer, MATLAB ``initnw`` style.

    Random unit directions scaled to 0.7 n_out^(1/n_in), biases spread evenly
    over the same magnitude, both mapped so that the tanh active region
    [-2, 2] covers the inputs' range ``input_range`` (n_in, 2) [min, max].
    """
    n_in = len(input_range)
    magnitude = 0.7 * n_out ** (1.0 / n_in)
    direction = rng.standard_normal((n_out, n_in))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    w = magnitude * direction
    b = magnitude * np.linspace(-1.0, 1.0, n_out) * np.sign(w[:, 0]) if n_out > 1 else np.zeros(1)
    w, b = 2.0 * w, 2.0 * b  # tanh's active input region is [-2, 2]
    lo, hi = input_range[:, 0], input_range[:, 1]
    width = np.where(hi > lo, hi - lo, 2.0)
    gain = 2.0 / width  # maps [lo, hi] to [-1, 1]
    offset = 1.0 - np.where(hi > lo, hi, 1.0) * gain
    return w * gain, b + w @ offset


def nguyen_widrow(input_range: np.ndarray, n_hidden: int, rng: np.random.Generator) -> MLPWeights:
    """Nguyen-Widrow initial weights of an N-H-1 network (MATLAB's default, ``initnw``).

    ``input_range`` (N, 2) holds [min, max] of each normalised input over the
    training split; the output layer sees hidden outputs in [-1, 1].
    """
    input_range = np.asarray(input_range, dtype=float)
    w1, b1 = _nguyen_widrow_layer(input_range, n_hidden, rng)
    w2, b2 = _nguyen_widrow_layer(np.tile([-1.0, 1.0], (n_hidden, 1)), 1, rng)
    return MLPWeights(w1, b1, w2[0], float(b2[0]))
