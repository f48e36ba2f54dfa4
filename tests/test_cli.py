"""The command line as a user runs it: real processes, real files."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from nnda.data.dataset import collection_members, read_dataset


def nnda(*args, cwd):
    return subprocess.run([sys.executable, "-m", "nnda", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def test_presets_lists_every_preset(tmp_path):
    out = nnda("presets", cwd=tmp_path)
    assert out.returncode == 0
    for name in ("train01", "train17", "T7", "S1", "S6", "validation"):
        assert name in out.stdout


def test_generate_preset_then_plot(tmp_path):
    out = nnda("generate", "--preset", "S3", "--seed", "7", "--out", "data/S3", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    ds = read_dataset(tmp_path / "data/S3")
    assert ds.seed == 7 and ds.scenario.name == "S3"
    png = nnda("plot-scenario", "data/S3", "--out", "s3.png", cwd=tmp_path)
    assert png.returncode == 0, png.stderr
    assert (tmp_path / "s3.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_generate_monte_carlo_from_config(tmp_path):
    (tmp_path / "my.toml").write_text(
        'name = "mine"\nduration_s = 20\n[clutter]\ncount = 5\n'
        '[[targets]]\nname = "a"\nx_m = 0\ny_m = 12000\nheading_deg = 90\nspeed_m_s = 100\n'
        'segments = [{duration_s = 20}]\n')
    out = nnda("generate", "--config", "my.toml", "--runs", "4", "--seed", "3", "--out", "data/mine", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    members = collection_members(tmp_path / "data/mine")
    assert [m.name for m in members] == ["run-0000", "run-0001", "run-0002", "run-0003"]
    assert [read_dataset(m).run for m in members] == [0, 1, 2, 3]
    manifest = json.loads((tmp_path / "data/mine/collection.json").read_text())
    assert manifest["format"] == "nnda.collection"


@pytest.mark.parametrize("args, message", [
    (("--preset", "S9"), "unknown preset 'S9'"),
    (("--config", "bad.toml"), "targets.0.speed_m_s"),
    (("--config", "nothing.toml"), "no such scenario file"),
    (("--config", "my[v2].toml"), "my[v2].toml"),  # brackets are printed as they are, not read as markup
    ((), "exactly one of --preset or --config"),
])
def test_generate_bad_input_is_one_clear_line_and_writes_nothing(tmp_path, args, message):
    (tmp_path / "bad.toml").write_text(
        'name = "bad"\nduration_s = 20\n[[targets]]\nname = "a"\nx_m = 0\ny_m = 12000\n'
        'heading_deg = 90\nspeed_m_s = -100\nsegments = [{duration_s = 20}]\n')
    out = nnda("generate", *args, "--out", "data/x", cwd=tmp_path)
    assert out.returncode == 2
    assert message in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "data").exists() or list((tmp_path / "data").iterdir()) == []


def test_generate_refuses_to_overwrite(tmp_path):
    assert nnda("generate", "--preset", "T3", "--out", "d", cwd=tmp_path).returncode == 0
    again = nnda("generate", "--preset", "T3", "--out", "d", cwd=tmp_path)
    assert again.returncode == 2 and "already exists" in again.stderr


def test_usage_errors_are_one_plain_line_and_help_still_works(tmp_path):
    bare = nnda(cwd=tmp_path)
    assert bare.returncode == 2 and "Usage:" in bare.stdout and bare.stderr == ""  # no arguments: the help
    assert nnda("generate", "--help", cwd=tmp_path).returncode == 0
    wrong = nnda("generate", "--preset", "S1", "--out", "d", "--runs", "0", cwd=tmp_path)
    assert wrong.returncode == 2 and wrong.stderr.count("\n") == 1
    assert wrong.stderr.startswith("error: Invalid value for '--runs'") and "nnda generate --help" in wrong.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("command", "shown"), [
    ("import-detections", "[[sensors]]"), ("run", "nnda[dask]"), ("reentry", "[reentry]"), ("tbd", "[tbd]"),
    ("pedestrian", "[pedestrian]")])
def test_help_shows_brackets_as_written(command, shown):
    """Square brackets in a help text reach the terminal (Rich would read "[dask]" as a style and drop it)."""
    from typer.testing import CliRunner

    from nnda.app.cli import app

    out = CliRunner().invoke(app, [command, "--help"], terminal_width=200).output
    assert shown in " ".join(out.split()), out
