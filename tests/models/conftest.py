"""Fixtures of the models tests: a hand-made dataset with known pairs, and the training pairs."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.dataset import Dataset, Detections, Truth
from nnda.data.generator import generate
from nnda.data.presets import resolve
from nnda.data.scenario import Scenario, Segment, Target
from nnda.data.sensor import cart_to_polar
from nnda.models.pairs import PairSet, pairs_from_datasets


def _make_dataset(contacts: list[tuple[int, float, float, int]], n_scans: int, n_targets: int = 1) -> Dataset:
    """A dataset from explicit contacts (scan, x m, y m, target id or -1); truth has every target at every scan.

    The scenario only supplies the sensor, scan period and target count; the
    truth positions are the target's contacts where it has one (else 0, 0).
    """
    targets = [Target(name=f"T{i}", x_m=0.0, y_m=10_000.0 + 1000 * i, heading_deg=0.0, speed_m_s=100.0,
                      segments=[Segment(duration_s=2.0 * n_scans)]) for i in range(n_targets)]
    scenario = Scenario(name="hand", duration_s=2.0 * n_scans, targets=targets)
    c = sorted(contacts, key=lambda r: (r[0], cart_to_polar(np.float64(r[1]), np.float64(r[2]))[1]))
    scan = np.array([r[0] for r in c], dtype=np.int32)
    x, y = np.array([r[1] for r in c], float), np.array([r[2] for r in c], float)
    tid = np.array([r[3] for r in c], dtype=np.int32)
    rng, az = cart_to_polar(x, y)
    det = Detections(scan, 2.0 * scan, rng, az, x, y, tid < 0, tid)
    tscan = np.repeat(np.arange(1, n_scans + 1, dtype=np.int32), n_targets)
    ttid = np.tile(np.arange(n_targets, dtype=np.int32), n_scans)
    tx, ty, hit = np.zeros(tscan.size), np.zeros(tscan.size), np.zeros(tscan.size, bool)
    for k, xx, yy, t in c:
        if t >= 0:
            i = (k - 1) * n_targets + t
            tx[i], ty[i], hit[i] = xx, yy, True
    truth = Truth(tscan, 2.0 * tscan, ttid, tx, ty, np.zeros(tscan.size), np.zeros(tscan.size), hit)
    return Dataset(scenario, 0, 0, det, truth)


@pytest.fixture(scope="session")
def make_dataset():
    """The `_make_dataset` builder: contacts (scan, x, y, target id) -> Dataset."""
    return _make_dataset


@pytest.fixture(scope="session")
def train_pairs() -> PairSet:
    """Pairs of the 17 training presets, seed 0 (the spec's training set)."""
    return pairs_from_datasets(generate(s, 0) for s in resolve("train"))


def pytest_configure(config):
    # torch.func's first call imports torch._dynamo, which warns about its own use of torch.jit
    config.addinivalue_line("filterwarnings", "ignore:`torch.jit.script` is deprecated:DeprecationWarning")
