"""Shared fixtures of the tracking tests: a small trained association model on disk."""

from __future__ import annotations

from pathlib import Path

import pytest

from nnda.data.generator import generate
from nnda.data.presets import resolve
from nnda.models.experiment import fit
from nnda.models.pairs import pairs_from_datasets
from nnda.models.scorer import save_model


@pytest.fixture(scope="session")
def model_file(tmp_path_factory) -> Path:
    """A 3-5-1 scorer trained by LM on the 17 training presets (seed 0), as the tracker would load it."""
    pairs = pairs_from_datasets(generate(s, 0) for s in resolve("train"))
    result = fit(pairs, "lm", n_hidden=5, seed=0)
    return save_model(result.scorer, tmp_path_factory.mktemp("model") / "model.json")


def pytest_configure(config):
    # torch.func's first call imports torch._dynamo, which warns about its own use of torch.jit
    config.addinivalue_line("filterwarnings", "ignore:`torch.jit.script` is deprecated:DeprecationWarning")


@pytest.fixture(scope="session")
def ext_model_file(tmp_path_factory) -> Path:
    """A 9-5-1 scorer on the IMM-extended features, trained by LM (best of 3 starts) on the training presets."""
    pairs = pairs_from_datasets((generate(s, 0) for s in resolve("train")), features="imm-innovation-9")
    result = fit(pairs, "lm", n_hidden=5, seed=0, starts=3)
    return save_model(result.scorer, tmp_path_factory.mktemp("ext-model") / "model.json")
