"""The N-H-1 tanh network as a torch function of its flat weight vector (float64).

Written as a pure function of ``theta`` (the `nnda.models.mlp` layout), so
that torch.func can differentiate the residuals with respect to all
weights at once. `nnda.models.mlp.MLPWeights` is the numpy twin used to
score pairs without torch.
"""

from __future__ import annotations

import numpy as np

from nnda.extras import require
from nnda.models.mlp import unpack

torch = require("torch", "training the association network")

DTYPE = torch.float64


def as_tensor(a: np.ndarray) -> torch.Tensor:
    """A float64 torch copy of a numpy array."""
    return torch.tensor(np.asarray(a, dtype=float), dtype=DTYPE)


def forward(theta: torch.Tensor, x: torch.Tensor, n_hidden: int) -> torch.Tensor:
    """Network outputs (P,) for flat weights ``theta`` (K,) and normalised inputs ``x`` (P, N)."""
    w1, b1, w2, b2 = unpack(theta, x.shape[1], n_hidden)
    return torch.tanh(torch.tanh(x @ w1.T + b1) @ w2 + b2)


def mse(theta: torch.Tensor, x: torch.Tensor, y: torch.Tensor, n_hidden: int) -> torch.Tensor:
    """Mean squared error of the outputs against targets ``y`` (P,) in {-1, +1}."""
    e = forward(theta, x, n_hidden) - y
    return e @ e / len(y)
