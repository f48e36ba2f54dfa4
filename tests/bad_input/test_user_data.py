"""A user's own files: `nnda import-detections` and `nnda track` refuse bad input, naming file, row and column,
and leave every file as it was (an earlier output included)."""

from __future__ import annotations

import pytest
from cli_run import assert_one_line_error, nnda_process

from dataset_edits import snapshot

HEADER = "time,range,azimuth,sensor,target_id\n"
GOOD = ["2,12000,0.5,radar,7", "2,15000,1.0,radar,", "4,12100,0.51,radar,7"]


@pytest.fixture
def user_files(tmp_path):
    """``plots.csv`` (good), a truth file, and an earlier import at ``ds`` that a refusal must keep."""
    (tmp_path / "plots.csv").write_text(HEADER + "\n".join(GOOD) + "\n")
    (tmp_path / "truth.csv").write_text("time,target_id,x,y,vx,vy\n2,7,5700,10900,100,0\n4,7,5900,10900,100,0\n")
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "earlier.txt").write_text("an earlier output\n")
    return tmp_path


def _bad(root, rows, header=HEADER):
    (root / "bad.csv").write_text(header + "\n".join(rows) + "\n")
    return "bad.csv"


@pytest.mark.parametrize("rows, fragments", [
    (GOOD + ["six,13000,0.3,radar,"], ("bad.csv: data row 4 (line 5), column 'time'", "'six', not a number")),
    (GOOD + ["6,NaN,0.3,radar,"], ("data row 4 (line 5), column 'range'", "must be a finite number")),
    (GOOD + ["2,13000,0.3,radar,"], ("data row 4 (line 5), column 'time'", "goes back")),
    (GOOD + ["6,13000,-4,radar,"], ("data row 4 (line 5), column 'azimuth'", "outside [-pi, 2 pi) rad")),
    (GOOD + ["6,13000,0.3,west,"], ("data row 4 (line 5), column 'sensor'", "unknown sensor 'west'")),
    (GOOD + ["6,13000,0.3,radar,9"], ("data row 4 (line 5), column 'target_id'", "target '9' is not in")),
])
def test_a_bad_cell_is_refused_with_its_row_and_column(user_files, refused, rows, fragments):
    refused(user_files, "import-detections", _bad(user_files, rows), "--out", "ds", "--overwrite", "--truth",
            "truth.csv", "--sensor", "scan_period_s=2", fragments=fragments)


def test_a_missing_column_unknown_unit_and_bad_options(user_files, refused, nnda):
    refused(user_files, "import-detections", _bad(user_files, ["2,12000"], header="t,range\n"), "--out", "new",
            fragments=("bad.csv: required column(s) 'time' missing", "the file has t, range"))
    for args, fragment in ((["--azimuth-unit", "gon"], "--azimuth-unit 'gon': unknown unit"),
                           (["--column", "speed=v"], "unknown column name 'speed'"),
                           (["--sensor", "colour=red"], "unknown sensor field 'colour'"),
                           (["--sensor", "scan_period_s=-2"], "scan_period_s")):
        before = snapshot(user_files)
        outcome = nnda("import-detections", "plots.csv", "--out", "new", *args, cwd=user_files)
        assert outcome.code == 2 and outcome.err.startswith("error: ") and fragment in outcome.err, outcome.err
        assert "Traceback" not in outcome.err and snapshot(user_files) == before


def test_an_existing_output_an_input_as_output_and_a_file_of_another_type(user_files, refused):
    refused(user_files, "import-detections", "plots.csv", "--out", "ds", fragments=("ds: already exists",))
    refused(user_files, "import-detections", "plots.csv", "--out", ".", fragments=("the current directory",))
    (user_files / "plots.xlsx").write_text("x")
    refused(user_files, "import-detections", "plots.xlsx", "--out", "new", fragments=("unknown file type '.xlsx'",))


def test_track_refuses_before_writing(user_files, refused, nnda):
    assert nnda("import-detections", "plots.csv", "--out", "imported", "--sensor", "scan_period_s=2",
                cwd=user_files).code == 0
    (user_files / "tracks").mkdir()
    refused(user_files, "track", "imported", "--tracker", "mht", "--out", "tracks", fragments=("already exists",))
    refused(user_files, "track", "imported", "--tracker", "kalman", "--out", "t2", fragments=("unknown tracker",))
    refused(user_files, "track", "imported", "--tracker", "mht", "--out", "imported/t",
            fragments=("lies inside the input imported",))
    refused(user_files, "track", "missing", "--tracker", "mht", "--out", "t2", fragments=("no such dataset",))
    (user_files / "c.toml").write_text("gate = -1\n")
    before = snapshot(user_files)
    outcome = nnda("track", "imported", "--tracker", "gnn", "--config", "c.toml", "--out", "t2", cwd=user_files)
    assert outcome.code == 2 and outcome.err.startswith("error: tracker config c.toml: invalid gnn config")
    assert "gate" in outcome.err and snapshot(user_files) == before


def test_a_bad_file_as_a_user_meets_it(user_files):
    bad = _bad(user_files, GOOD + ["6,13000,9,radar,"])
    before = snapshot(user_files)
    outcome = nnda_process("import-detections", bad, "--out", "ds", "--overwrite", cwd=user_files)
    assert_one_line_error(outcome, "bad.csv: data row 4 (line 5), column 'azimuth'")
    assert snapshot(user_files) == before
