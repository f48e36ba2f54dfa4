"""Damaged model files, and outputs of `nnda train` and `nnda evaluate` that would replace their inputs."""

from __future__ import annotations

import json
import math
import re
import shutil

import numpy as np
import pytest
from cli_run import assert_one_line_error, nnda_process

from dataset_edits import snapshot
from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, load_model, save_model


@pytest.fixture(scope="module")
def train01(tmp_path_factory):
    """One training preset (one target, about 170 pairs)."""
    return write_dataset(generate(preset("train01"), seed=0), tmp_path_factory.mktemp("train01") / "ds")


@pytest.fixture
def root(tmp_path, train01):
    """``ds`` (a copy of train01) and ``m/model.json``, a 3-2-1 model."""
    shutil.copytree(train01, tmp_path / "ds")
    weights = MLPWeights.from_vector(np.linspace(-1, 1, n_weights(3, 2)), 3, 2)
    save_model(Scorer(weights, Normaliser(np.array([90.0, 0.1, 4.0]), np.array([100.0, 28.0, 2.4])),
                      metadata={"method": "lm"}), tmp_path / "m" / "model.json")
    return tmp_path


def _edit(path, change):
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc, indent=1))


def _bump_weight(doc):
    doc["network"]["weights"][3] += 0.001


@pytest.mark.parametrize("change, fragments", [
    (_bump_weight, ("m/model.json: corrupt model file: its content does not match field 'sha256'",
                    "retrain it or restore a good copy")),
    (lambda d: d.pop("sha256"), ("m/model.json: corrupt model file", "(recorded None...)")),
    (lambda d: d["metadata"].update(method="gd"), ("m/model.json: corrupt model file",)),
    (lambda d: d.update(format_version=3), ("m/model.json: field 'format_version' is 3", "reads version 1 or 2 only")),
    (lambda d: d.update(format_version=1, network={**d["network"], "weights": [math.nan] * 11}),
     ("m/model.json: field 'network.weights' must be a list of 11 finite numbers",)),
])
def test_damaged_model_files_are_refused(root, refused, change, fragments):
    _edit(root / "m" / "model.json", change)
    refused(root, "evaluate", "m", "--data", "ds", fragments=fragments)


def test_a_flipped_byte_in_a_weight_as_a_user_meets_it(root):
    path = root / "m" / "model.json"
    text = path.read_text()
    digit = re.compile(r'"weights": \[\s*-?\d\.(\d)').search(text).start(1)  # a decimal of the first weight
    path.write_text(text[:digit] + ("1" if text[digit] != "1" else "2") + text[digit + 1:])
    before = snapshot(root)
    outcome = nnda_process("evaluate", "m", "--data", "ds", cwd=root)
    assert_one_line_error(outcome, "m/model.json: corrupt model file")
    assert snapshot(root) == before


def test_a_format_1_model_without_a_digest_still_loads(root, nnda):
    path = root / "m" / "model.json"
    want = load_model(path).weights.to_vector()
    _edit(path, lambda d: (d.pop("sha256"), d.update(format_version=1)))
    assert np.array_equal(load_model(path).weights.to_vector(), want)
    done = nnda("evaluate", "m", "--data", "ds", cwd=root)
    assert done.code == 0 and "Sensitivity" in done.out, done.err


@pytest.mark.parametrize("args, fragments", [
    (("train", "--data", "ds", "--out", "ds", "--overwrite"), ("--out ds is the input ds",)),
    (("train", "--data", "ds", "--out", "ds", "--overwrite", "--ablation", "--repeats", "2"),
     ("--out ds is the input ds",)),
    (("train", "--data", "ds", "--out", "ds/model", "--overwrite"), ("--out ds/model lies inside the input ds",)),
    (("train", "--data", "data/ds", "--out", "data", "--overwrite"), ("--out data contains the input data/ds",)),
    (("train", "--data", "ds", "--out", ".", "--overwrite"), ("--out . is the current directory",)),
    (("train", "--data", "ds", "--out", "kept.txt", "--overwrite"),
     ("kept.txt: is a file, not a directory; refusing to replace it with one",)),
    (("train", "--data", "nowhere", "--out", "x"), ("nowhere: no such dataset directory",)),
    (("evaluate", "m", "--data", "ds", "--out", "m", "--overwrite"), ("--out m is the input m",)),
    (("evaluate", "m", "--data", "ds", "--out", "m/eval"), ("--out m/eval lies inside the input m",)),
    (("evaluate", "m", "--data", "ds", "--out", "ds", "--overwrite"), ("--out ds is the input ds",)),
    (("evaluate", "m", "--data", "ds", "--out", "kept.txt", "--overwrite"), ("kept.txt: is a file, not a directory",)),
    (("evaluate", "nothing", "--data", "ds"), ("nothing: no such model file",)),
])
def test_outputs_never_replace_an_input_or_a_file(root, refused, args, fragments):
    (root / "kept.txt").write_text("mine")
    shutil.copytree(root / "ds", root / "data" / "ds")
    refused(root, *args, fragments=fragments)
