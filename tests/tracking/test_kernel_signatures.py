"""The compiled kernels see one array layout whoever calls them: column views, transposes, read-only broadcasts
and np.nonzero's strided outputs are made C-contiguous and writeable in the kernels' Python wrappers, so each
kernel is compiled once (numba compiles a version per layout, ~1-15 s each on an empty cache).

Each test feeds a wrapper the odd layouts its callers pass and asserts that every version the kernel holds
takes C-contiguous writeable arrays only (a version for another layout would have been compiled by the call)."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.filters import imm_kernels
from nnda.filters.imm import IMM
from nnda.models import feature_kernels
from nnda.models.context import context_features, with_context
from nnda.models.features import candidate_pairs, sector
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, _scores
from nnda.tracking import clutter_density, kbest, neural_matching
from nnda.tracking.clutter_density import local_density, unexplained_density
from nnda.tracking.kbest import k_best_assignments
from nnda.tracking.output import CONFIRMED


def odd_layouts(kernel) -> list[str]:
    """The array arguments of ``kernel``'s compiled versions that are not C-contiguous and writeable."""
    return [f"argument {i}: {t}" for sig in kernel.signatures for i, t in enumerate(sig)
            if hasattr(t, "layout") and (t.layout != "C" or not t.mutable)]


def columns(a: np.ndarray) -> np.ndarray:
    """``a`` (N, ...) as a strided view: its rows interleaved with a second copy's, every other row taken."""
    wide = np.empty((2 * len(a), *a.shape[1:]), a.dtype)
    wide[::2] = a
    return wide[::2]


def test_the_imm_wrappers_pass_one_layout():
    imm = IMM()
    rng = np.random.default_rng(0)
    history = rng.uniform(1_000.0, 9_000.0, (5, 8))  # the tracker's history: fixes are column views of it
    cov = np.broadcast_to(np.diag([100.0, 100.0]), (5, 2, 2))  # read-only, as a position measurement's noise
    state = imm.start(history[:, 0:2], history[:, 3:5], cov, history[:, 2])
    imm.start(history[:, 0:2], history[:, 3:5], cov[:1], 2.0)  # one track, a scalar interval (read-only, C)
    pred = imm.predict(state, 2.0)
    z = np.column_stack([np.hypot(history[:, 3], history[:, 4]), np.full(5, 0.5)])
    imm.update(pred, columns(z))
    imm.mahalanobis(pred.gating.measurement, columns(z))
    for kernel in (imm_kernels.start, imm_kernels.update, imm_kernels.mahalanobis):
        assert odd_layouts(kernel) == [], kernel.py_func.__name__


def test_the_feature_wrappers_pass_one_layout():
    rng = np.random.default_rng(1)
    history = rng.uniform(-5_000.0, 5_000.0, (4, 8))
    history[:, 2], history[:, 5] = 0.0, 2.0
    xy = rng.uniform(-5_000.0, 5_000.0, (9, 2))
    z = np.column_stack([np.hypot(*xy.T), np.arctan2(xy[:, 0], xy[:, 1]) % (2 * np.pi)])
    candidate_pairs(history[:, 3:5], history[:, 5], history[:, 6], xy, z[:, 1], 4.0)
    sector(np.broadcast_to(0.3, (3,)))  # a read-only view, as a dataset's column
    d2 = rng.uniform(0.0, 9.0, 6)
    context_features(np.arange(6) % 2, np.arange(6) % 3, columns(d2))
    with_context(rng.uniform(0.0, 9.0, (6, 9)), np.arange(6) % 2, np.arange(6) % 3)
    for kernel in (feature_kernels.candidates, feature_kernels.sectors, feature_kernels.context):
        assert odd_layouts(kernel) == [], kernel.py_func.__name__


def test_the_scorer_passes_one_layout():
    weights = MLPWeights.from_vector(np.linspace(-1.0, 1.0, n_weights(3, 5)), 3, 5)  # w1, b1: strided views
    scorer = Scorer(weights, Normaliser(np.zeros(3), np.ones(3)))
    features = np.asfortranarray(np.random.default_rng(2).normal(size=(7, 3)))  # a column selection's order
    assert np.array_equal(scorer(features), scorer(np.ascontiguousarray(features)))
    assert odd_layouts(_scores) == []


def test_k_best_passes_one_layout():
    cost = np.random.default_rng(3).uniform(0.0, 1.0, (5, 3))  # more rows than columns: solved transposed
    cost[1, 2] = np.inf
    k_best_assignments(cost, 4)
    for kernel in (kbest._reassigned, kbest._one_child, kbest._settled, kbest._shift):
        assert odd_layouts(kernel) == [] and len(kernel.signatures) <= 1, kernel.py_func.__name__


def test_the_clutter_density_passes_one_table_type():
    """Without a sensor the empty covered-part table is float32, as a sensor's lazily filled one; a single
    query's ``own`` count is a copy, not a read-only broadcast."""
    points = np.random.default_rng(4).uniform(-3_000.0, 3_000.0, (6, 2))
    local_density(points, points, 1_000.0)
    unexplained_density(points, points[:1], 1_000.0, 1e8, None, points[:2], np.ones(2), 1.0)
    for kernel in (clutter_density._density, clutter_density._unexplained):
        assert odd_layouts(kernel) == [], kernel.py_func.__name__
        tables = {str(sig[3]) for sig in kernel.signatures}
        assert tables <= {"array(float32, 2d, C)"}, (kernel.py_func.__name__, tables)
    assert all(len(sig) == 6 and str(sig[5]) == "int64" for sig in clutter_density._density.signatures)


def test_the_neural_stages_pass_one_layout():
    status = np.array([CONFIRMED, CONFIRMED, CONFIRMED], np.int8)
    counts = np.array([[3, 1, 1], [4, 0, 0], [2, 2, 2]])  # the tracker's counts: consecutive is a column view
    pairs = np.array([0, 1, 2]), np.array([0, 1, 1]), np.array([0.9, 0.8, 0.7])
    gate = np.array([0, 1]), np.array([0, 1]), np.array([1.0, 2.0])
    neural_matching.first_stage(*pairs, status, counts[:, 2], 3, True, True, 1, 2, 0.0, *gate)
    neural_matching.reacquired(np.array([-1, 1, -1]), status, counts[:, 2], CONFIRMED, 1, *gate, 9.21, 3)
    for kernel in (neural_matching._first_stage, neural_matching._reacquired):
        assert odd_layouts(kernel) == [], kernel.py_func.__name__


@pytest.mark.parametrize("kernel", [feature_kernels._sort_small, kbest._shift])
def test_integer_arguments_are_not_compiled_as_literals(kernel):
    """A counter started at a literal 0 or -1 would compile the callee for the literal first, then for int64."""
    rng = np.random.default_rng(5)
    history = rng.uniform(-2_000.0, 2_000.0, (6, 8))
    xy = rng.uniform(-2_000.0, 2_000.0, (40, 2))
    candidate_pairs(history[:, 3:5].copy(), np.zeros(6), np.zeros(6), xy, np.zeros(40), 4.0)
    k_best_assignments(rng.uniform(0.0, 1.0, (4, 4)), 6)
    assert [str(t) for sig in kernel.signatures for t in sig if "Literal" in str(t)] == []
