"""`nnda tune`: the files it writes, their bytes under a seed, and bad input as one error line."""

from __future__ import annotations

import sys

import pytest
from tests.study.test_tuning import fast_scene, without_truth

from nnda import extras
from nnda.app.cli import main
from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.errors import NndaError
from nnda.files import read_config
from nnda.study.track import run_tracker
from nnda.tracking.registry import check_config

FILES = ("config.toml", "trials.csv", "tune.md")


@pytest.fixture(scope="module")
def fast_dir(tmp_path_factory):
    return write_dataset(generate(fast_scene(), 5), tmp_path_factory.mktemp("fast") / "fast")


def nnda(monkeypatch, capsys, *args) -> tuple[int, str]:
    """Run the command line in this process: (exit status, stderr)."""
    monkeypatch.setattr(sys, "argv", ["nnda", *map(str, args)])
    with pytest.raises(SystemExit) as done:
        main()
    return done.value.code, capsys.readouterr().err


def test_tune_writes_a_config_that_track_runs_and_beats_the_default(fast_dir, tmp_path, monkeypatch, capsys):
    out = tmp_path / "tuned"
    code, err = nnda(monkeypatch, capsys, "tune", fast_dir, "--tracker", "gnn", "--out", out, "--trials", "6")
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == sorted(FILES)
    config = read_config(out / "config.toml", "tuned config")
    assert config["lifecycle"]["v_max"] > 320.0 and set(config) == {"gate", "motion", "lifecycle"}
    check_config("gnn", config)
    trials = (out / "trials.csv").read_text().splitlines()
    assert trials[0].startswith("number,state,objective,motion.cv_sigma_q") and len(trials) == 7
    report = (out / "tune.md").read_text()
    assert "# nnda tune: gnn on fast" in report and "| GOSPA (m) |" in report and "held out" in report
    code, err = nnda(monkeypatch, capsys, "track", fast_dir, "--tracker", "gnn", "--config", out / "config.toml",
                     "--out", tmp_path / "tracks", "--quiet")
    assert code == 0, err
    ds = generate(fast_scene(), 5)
    assert run_tracker(ds, "gnn", config).scores.values["gospa"] < run_tracker(ds, "gnn").scores.values["gospa"]


def test_the_same_seed_gives_the_same_bytes(fast_dir, tmp_path, monkeypatch, capsys):
    for name in ("a", "b"):
        code, err = nnda(monkeypatch, capsys, "tune", fast_dir, "--tracker", "gnn", "--out", tmp_path / name,
                         "--trials", "4", "--seed", "7")
        assert code == 0, err
    for f in FILES:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


def test_a_switching_penalty_of_zero_is_the_plain_objective_and_one_above_changes_it(fast_dir, tmp_path, monkeypatch,
                                                                                     capsys):
    runs = {"plain": (), "zero": ("--switching-penalty", "0"), "charged": ("--switching-penalty", "1000")}
    for name, extra in runs.items():
        code, err = nnda(monkeypatch, capsys, "tune", fast_dir, "--tracker", "gnn", "--out", tmp_path / name,
                         "--trials", "4", "--seed", "3", *extra)
        assert code == 0, err
    for f in FILES:
        assert (tmp_path / "zero" / f).read_bytes() == (tmp_path / "plain" / f).read_bytes()
    plain, charged = ((tmp_path / name / "trials.csv").read_text().splitlines() for name in ("plain", "charged"))
    objective = [[line.split(",")[2] for line in rows[1:]] for rows in (plain, charged)]
    assert objective[0] != objective[1] and [len(o) for o in objective] == [4, 4]
    drop_objective = [[line.split(",")[:2] + line.split(",")[3:] for line in rows] for rows in (plain, charged)]
    assert drop_objective[0] == drop_objective[1]  # the same trials: only their objective moved
    report = (tmp_path / "charged" / "tune.md").read_text()
    assert "objective (minimised): mean over the tuning scans of GOSPA with switching penalty gamma = 1000 m" in report
    assert "| GOSPA with switching penalty 1000 m (m) |" in report and "| Track switches (GOSPA assignment) |" in report
    assert "switching penalty" not in (tmp_path / "plain" / "tune.md").read_text()


def test_keep_holds_fields_at_the_base_config_and_says_so(fast_dir, tmp_path, monkeypatch, capsys):
    out = tmp_path / "kept"
    code, err = nnda(monkeypatch, capsys, "tune", fast_dir, "--tracker", "gnn", "--out", out, "--trials", "3",
                     "--keep", "lifecycle.v_min", "--keep", "gate")
    assert code == 0, err
    assert "- kept at the base config's values: `lifecycle.v_min`, `gate`" in (out / "tune.md").read_text()
    config = read_config(out / "config.toml", "tuned config")
    assert "gate" not in config and "v_min" not in config["lifecycle"] and config["lifecycle"]["v_max"] > 320.0
    assert "gate" not in (out / "trials.csv").read_text().splitlines()[0].split(",")


def test_a_base_config_keeps_its_fields_and_without_truth_the_config_is_valid(tmp_path, monkeypatch, capsys):
    data = write_dataset(without_truth(generate(fast_scene(), 5)), tmp_path / "no-truth")
    base = tmp_path / "base.toml"
    base.write_text('[lifecycle]\nconfirmation = "mn"\nv_max = 400.0\nmax_tracks = 500\n')
    code, err = nnda(monkeypatch, capsys, "tune", data, "--tracker", "gnn", "--out", tmp_path / "t",
                     "--config", base, "--trials", "3")
    assert code == 0, err
    config = read_config(tmp_path / "t" / "config.toml", "tuned config")
    assert config["lifecycle"]["confirmation"] == "mn" and config["lifecycle"]["max_tracks"] == 500
    assert "lifecycle.m" in (tmp_path / "t" / "trials.csv").read_text()
    check_config("gnn", config)
    assert "innovation consistency" in (tmp_path / "t" / "tune.md").read_text()


@pytest.mark.parametrize(("args", "message"), [
    (("--tracker", "kalman"), "kalman"),
    (("--tracker", "gnn", "--trials", "0"), "--trials 0: give a whole number of trials, 1 or more"),
    (("--tracker", "gnn", "--fraction", "1.5"), "--fraction 1.5: the share of the scans tuned on must lie"),
    (("--tracker", "gnn", "--config", "{mht}"), "n_scan are options of tracker(s) mht"),
    (("--tracker", "gnn", "--switching-penalty", "-5"), "--switching-penalty -5.0: must be a number of metres >= 0"),
    (("--tracker", "gnn", "--switching-penalty", "nan"), "--switching-penalty nan: must be a number of metres >= 0"),
])
def test_bad_input_is_one_error_line(fast_dir, tmp_path, monkeypatch, capsys, args, message):
    mht = tmp_path / "mht.toml"
    mht.write_text("n_scan = 4\n")
    args = tuple(str(mht) if a == "{mht}" else a for a in args)
    code, err = nnda(monkeypatch, capsys, "tune", fast_dir, "--out", tmp_path / "t", *args)
    assert code == 2 and err.startswith("error: ") and message in err, err
    assert not (tmp_path / "t").exists()


def test_optuna_missing_is_one_error_line(fast_dir, tmp_path, monkeypatch, capsys):
    def missing(module, purpose):
        raise NndaError(f'{purpose} needs {module}, which is not installed here: pip install "nnda[tune]"')

    monkeypatch.setattr(extras, "require", missing)
    code, err = nnda(monkeypatch, capsys, "tune", fast_dir, "--tracker", "gnn", "--out", tmp_path / "t")
    assert code == 2 and err == 'error: nnda tune needs optuna, which is not installed here: pip install "nnda[tune]"\n'
