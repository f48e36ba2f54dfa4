from __future__ import annotations

import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from nnda.app.cli import app
from nnda.errors import ConfigError
from nnda.models.pairs import load_pairs
from nnda.models.scorer import Scorer, load_model, save_model

runner = CliRunner()


@pytest.fixture(scope="module")
def train_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("data") / "train"
    result = runner.invoke(app, ["generate", "--preset", "train", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_train_writes_a_model_directory_and_evaluate_reads_it(train_dir, tmp_path):
    out = tmp_path / "lm"
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--method", "lm", "--hidden", "3",
                                 "--seed", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "Sensitivity" in result.output and "Levenberg-Marquardt, 3-3-1" in result.output
    assert sorted(p.name for p in out.iterdir()) == ["loss.png", "metrics.md", "model.json", "roc.png",
                                                     "training.json"]
    scorer = load_model(out)
    assert scorer.weights.n_hidden == 3 and scorer.metadata["seed"] == 2
    training = json.loads((out / "training.json").read_text())
    assert len(training["loss_per_epoch"]["validation"]) == training["epochs"] + 1

    result = runner.invoke(app, ["evaluate", str(out), "--data", str(train_dir), "--out", str(tmp_path / "ev")])
    assert result.exit_code == 0, result.output
    evaluation = json.loads((tmp_path / "ev" / "evaluation.json").read_text())
    pairs = load_pairs(train_dir)
    assert evaluation["metrics"]["tp"] + evaluation["metrics"]["fn"] == pairs.n_positive
    assert evaluation["metrics"] == training["metrics"]["all"]


def test_sweep_and_repeats_modes(train_dir, tmp_path):
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--sweep", "1-2", "--restarts", "2",
                                 "--out", str(tmp_path / "sweep")])
    assert result.exit_code == 0, result.output
    sweep = json.loads((tmp_path / "sweep" / "sweep.json").read_text())
    assert sweep["hidden_sizes"] == [1, 2] and len(sweep["runs"]) == 4
    assert (tmp_path / "sweep" / "sweep.png").is_file()
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--method", "lm", "--repeats", "2",
                                 "--hidden", "2", "--out", str(tmp_path / "rep")])
    assert result.exit_code == 0, result.output
    assert "thesis LM" in (tmp_path / "rep" / "repeats.md").read_text()


def test_bad_requests_leave_nothing_behind(train_dir, tmp_path):
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--method", "both", "--out", str(tmp_path / "x")])
    assert isinstance(result.exception, ConfigError)
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--sweep", "3-1", "--out", str(tmp_path / "x")])
    assert isinstance(result.exception, ConfigError) and "--sweep" in str(result.exception)
    assert list(tmp_path.iterdir()) == []


def test_cli_prints_a_clean_error_for_a_model_of_another_feature_version(tmp_path):
    model = tmp_path / "model.json"
    model.write_text(json.dumps({"format": "nnda.model", "format_version": 1,
                                 "feature_set": "kinematic-3", "feature_version": 99}))
    proc = subprocess.run([sys.executable, "-c", "from nnda.app.cli import main; main()", "evaluate", str(model),
                           "--data", str(tmp_path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "version 99" in proc.stderr and "Traceback" not in proc.stderr


def test_parse_sizes():
    from nnda.app.model_commands import parse_sizes
    assert parse_sizes("1-3,8") == [1, 2, 3, 8]
    assert parse_sizes("5") == [5]
    with pytest.raises(ConfigError):
        parse_sizes("0-2")
    assert parse_sizes("2,2,1") == [1, 2]


def test_extended_model_and_ablation_modes(train_dir, tmp_path):
    ext = tmp_path / "ext"
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--features", "imm-innovation-9", "--starts", "2",
                                 "--out", str(ext)])
    assert result.exit_code == 0, result.output
    scorer = load_model(ext)
    assert scorer.features.name == "imm-innovation-9" and scorer.weights.n_inputs == 9
    assert scorer.metadata["pair_options"]["features"] == "imm-innovation-9" and scorer.metadata["starts"] == 2
    result = runner.invoke(app, ["evaluate", str(ext), "--data", str(train_dir), "--out", str(tmp_path / "ev")])
    assert result.exit_code == 0, result.output  # evaluate rebuilds the pairs with the model's feature set
    training = json.loads((ext / "training.json").read_text())
    assert json.loads((tmp_path / "ev" / "evaluation.json").read_text())["metrics"] == training["metrics"]["all"]
    bare = load_model(ext)  # a model saved through the API records no pair options: evaluate still uses its set
    save_model(Scorer(bare.weights, bare.normaliser, bare.features, metadata={}), tmp_path / "bare.json")
    result = runner.invoke(app, ["evaluate", str(tmp_path / "bare.json"), "--data", str(train_dir)])
    assert result.exit_code == 0, result.output

    abl = tmp_path / "abl"
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--ablation", "--repeats", "2", "--starts", "1",
                                 "--out", str(abl)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in abl.iterdir()) == ["ablation.json", "ablation.md", "ablation_roc.png"]
    doc = json.loads((abl / "ablation.json").read_text())
    assert doc["format"] == "nnda.ablation" and doc["seeds"] == [0, 1]
    variants = {(r["history"], r["variant"]) for r in doc["results"]}
    assert len(variants) == 2 * 9 and ("true", "seed + mahalanobis_d2") in variants
    assert all(len(r["runs"]) == 2 and len(r["roc"]["tpr"]["lm"]) == len(r["roc"]["fpr"]) for r in doc["results"])
    assert doc["pairs"]["measured"]["own_contact"] == load_pairs(train_dir).n_positive
    assert "| extended | 9 |" in (abl / "ablation.md").read_text()
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--ablation", "--out", str(tmp_path / "x")])
    assert isinstance(result.exception, ConfigError) and "--repeats" in str(result.exception)
    assert not (tmp_path / "x").exists()


def test_train_with_encounters_and_dagger_records_its_recipe(train_dir, tmp_path):
    out = tmp_path / "ctx"
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--features", "imm-context-14", "--hidden", "3",
                                 "--encounters", "3", "--dagger", "1", "--dagger-ratio", "0.5", "--out", str(out)])
    assert result.exit_code == 0, result.output
    meta = load_model(out).metadata
    recipe = meta["recipe"]
    assert (recipe["encounters"], recipe["dagger"], recipe["dagger_ratio"]) == (3, 1, 0.5)
    (harvest,) = recipe["dagger_rounds"]
    oracle = load_pairs(train_dir, features="imm-context-14")
    assert meta["pairs"]["total"] > len(oracle) + harvest["harvested"] > len(oracle)  # encounters and harvest
    assert (out / "dagger" / "dagger-round-1.json").is_file()  # the model each round harvested with
    result = runner.invoke(app, ["train", "--data", str(train_dir), "--dagger", "1", "--repeats", "2",
                                 "--out", str(tmp_path / "bad")])
    assert result.exit_code != 0 and "one model" in str(result.exception or result.output)
