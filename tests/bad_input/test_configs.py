"""Bad scenario configs and command-line options of `nnda generate` (and the other commands' seeds).

Each refusal: exit status 2, one line naming what and where, nothing
written, nothing changed (`conftest.refused`).
"""

from __future__ import annotations

import pytest
from cli_run import TINY_TOML, assert_one_line_error, nnda_process

from dataset_edits import snapshot
from nnda.data import generator
from nnda.data.dataset import read_dataset


@pytest.fixture
def root(tmp_path):
    (tmp_path / "tiny.toml").write_text(TINY_TOML)
    return tmp_path


def _config(root, body: str, name: str = "bad.toml") -> str:
    (root / name).write_text(body)
    return name


@pytest.mark.parametrize("args, fragments", [
    (("generate", "--config", "tiny.toml", "--seed", "-1", "--out", "d"), ("'--seed'", "greater than or equal to 0")),
    (("generate", "--config", "tiny.toml", "--runs", "0", "--out", "d"), ("'--runs'",)),
    (("generate", "--config", "tiny.toml", "--max-detections", "0", "--out", "d"), ("'--max-detections'",)),
    (("train", "--data", "d", "--seed", "-1", "--out", "m"), ("'--seed'", "nnda train --help")),
    (("import-stonesoup", "--seed", "-1", "--out", "ss"), ("'--seed'",)),
    (("demo", "--seed", "-1", "--out", "demo"), ("'--seed'",)),
    (("generate", "--config", "tiny.toml", "--out", "d", "--colour", "red"), ("No such option: --colour",)),
    (("generate", "--preset", "S1", "--config", "tiny.toml", "--out", "d"), ("exactly one of --preset or --config",)),
])
def test_bad_options_are_one_line(root, refused, args, fragments):
    refused(root, *args, fragments=fragments)


def test_seed_minus_one_as_a_user_types_it(root):
    """The real entry point: ``python -m nnda`` in a new process."""
    before = snapshot(root)
    outcome = nnda_process("generate", "--config", "tiny.toml", "--seed", "-1", "--out", "d", cwd=root)
    assert_one_line_error(outcome, "Invalid value for '--seed'")
    assert snapshot(root) == before


@pytest.mark.parametrize("change, fragments", [
    # the square misses the radar's 5-30 km ring: clutter would be redrawn for ever
    ("[clutter]\ncount = 5\ncentre_m = [0.0, 60000.0]\nside_m = 2000.0\n",
     ("bad.toml", "scenario 'tiny': clutter of sensor 'radar': the square region (side 2000 m, centred at "
                  "(0, 60000) m)",
      "0.00% of its points inside the coverage", "at least 0.1% must be")),
    ("[clutter]\ncount = 5\nlaw = \"gaussian\"\ncentre_m = [0.0, 0.0]\nsigma_m = 500.0\n",
     ("scenario 'tiny': clutter of sensor 'radar': the gaussian region (sigma 500 m",)),
    ("[clutter]\ncount = 5\n", ()),  # the good config, as a control: the fragments below are added to all
])
def test_clutter_outside_the_coverage_is_refused_before_any_draw(root, refused, nnda, change, fragments):
    body = TINY_TOML.replace("[clutter]\ncount = 5\n", change)
    _config(root, body)
    if not fragments:
        assert nnda("generate", "--config", "bad.toml", "--out", "d", cwd=root).code == 0
        return
    for runs in ("1", "3"):
        refused(root, "generate", "--config", "bad.toml", "--runs", runs, "--out", "d", fragments=fragments)


@pytest.mark.parametrize("change, fragments", [
    (("duration_s = 6", "duration_s = 20000000"),
     ("bad.toml: scenario 'tiny': one dataset would hold up to 60,000,000 detections", "10,000,000 scans")),
    (("[clutter]\ncount = 5\n", "[clutter]\ncount = 5\n[sensor]\nscan_period_s = 1e-6\n"),
     ("up to 36,000,000 detections", "6,000,000 scans", "above the limit of 10,000,000")),
    (("count = 5", "count = 100000000"), ("up to 300,000,003 detections", "100,000,000 clutter points per sweep")),
])
def test_oversized_scenarios_fail_fast_with_the_number_and_the_flag(root, refused, change, fragments, monkeypatch):
    """Refused from the scenario's numbers alone: before the noise-free plan, the first work that grows with
    the schedule, is built (building it here fails the test)."""
    _config(root, TINY_TOML.replace(*change))
    args = ("--max-detections", "10000000") if "above the limit of 10,000,000" in fragments else ()

    def planned(*_):
        raise AssertionError("the plan was built before the size was refused")

    monkeypatch.setattr(generator.Plan, "of", planned)
    refused(root, "generate", "--config", "bad.toml", *args, "--out", "d",
            fragments=(*fragments, "--max-detections (nnda generate)", "max_detections="))


def test_the_limit_is_raised_with_max_detections(root, refused, nnda):
    refused(root, "generate", "--config", "tiny.toml", "--max-detections", "10", "--out", "d",
            fragments=("up to 18 detections", "above the limit of 10"))
    done = nnda("generate", "--config", "tiny.toml", "--max-detections", "18", "--out", "d", cwd=root)
    assert done.code == 0 and read_dataset(root / "d").detections.scan.size <= 18


def test_implausible_targets_are_warnings_naming_them(root, nnda):
    targets = (
        '[[targets]]\nname = "rocket"\nx_m = 0\ny_m = 12000\nheading_deg = 90\nspeed_m_s = 900\n'
        'segments = [{duration_s = 6, tangential_accel = 50}]\n'
        '[[targets]]\nname = "far"\nx_m = 90000\ny_m = 0\nheading_deg = 90\nspeed_m_s = 100\n'
        'segments = [{duration_s = 6}]\n'
        '[[targets]]\nname = "late"\nx_m = 0\ny_m = 12000\nheading_deg = 0\nspeed_m_s = 100\n'
        'start_time_s = 60\nsegments = [{duration_s = 6}]\n')
    _config(root, TINY_TOML.split("[[targets]]")[0].replace("count = 5", 'count = 5\nlaw = "annulus"') + targets,
            "odd.toml")
    done = nnda("generate", "--config", "odd.toml", "--out", "d", cwd=root)
    assert done.code == 0 and "Traceback" not in done.err
    lines = done.err.splitlines()
    assert lines == [
        "warning: scenario 'tiny': target 'rocket' reaches 1,200 m/s, faster than 1,000 m/s",
        "warning: scenario 'tiny': target 'far' is outside the coverage of the sensor sweeping at each of its 3 "
        "sweep(s): it is never detected",
        "warning: scenario 'tiny': target 'late' starts at 60 s, after the scenario's end (6 s): it has no scan",
    ]
    assert read_dataset(root / "d").scenario.name == "tiny"


@pytest.mark.parametrize("body, fragments", [
    (TINY_TOML.replace('name = "tiny"', 'name = ".."'), ("bad.toml: invalid scenario", "'..' cannot name a file")),
    ("name = [unclosed", ("bad.toml: not valid TOML",)),
    (TINY_TOML.replace("speed_m_s = 100", "speed_m_s = -100"), ("bad.toml: invalid scenario", "targets.0.speed_m_s")),
])
def test_invalid_configs_name_the_file_and_field(root, nnda, body, fragments):
    _config(root, body)
    before = snapshot(root)
    done = nnda("generate", "--config", "bad.toml", "--out", "d", cwd=root)
    assert done.code == 2 and done.err.startswith("error: ") and "Traceback" not in done.err
    assert all(f in done.err for f in fragments), done.err
    assert snapshot(root) == before


@pytest.mark.parametrize("out, overwrite, fragments", [
    (".", True, ("--out . is the current directory",)),
    (".", False, ("--out . is the current directory",)),
    ("..", True, ("--out .. contains the current directory",)),
    ("tiny.toml", True, ("--out tiny.toml is the input tiny.toml",)),
    ("conf", True, ("--out conf contains the input conf/inner.toml",)),
    ("kept.txt", True, ("kept.txt: is a file, not a directory; refusing to replace it with one",)),
    ("kept.txt", False, ("kept.txt: already exists (pass overwrite to replace it)",)),
])
def test_generate_out_may_not_be_an_input_the_working_directory_or_a_file(root, refused, out, overwrite, fragments):
    (root / "kept.txt").write_text("mine")
    (root / "conf").mkdir()
    (root / "conf" / "inner.toml").write_text(TINY_TOML)
    work = root / "work"
    work.mkdir()
    config = "conf/inner.toml" if out == "conf" else "tiny.toml"
    cwd = work if out == ".." else root
    config = f"../{config}" if cwd == work else config
    args = ("generate", "--config", config, "--out", out, *(("--overwrite",) if overwrite else ()))
    refused(root, *args, fragments=fragments, cwd=cwd)
