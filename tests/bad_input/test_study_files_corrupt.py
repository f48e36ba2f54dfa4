"""Corrupt files in a study directory: `nnda report DIR` ends in one "error:" line naming the file (exit 2),
never in a reader's traceback, whether or not ``checksums.json`` was updated to match the damaged file, and
writes nothing. A study directory of a few hand-made files keeps these fast; one slow test damages a real
study's tables."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_run import TINY_TOML, assert_one_line_error, nnda_process

from nnda.errors import DatasetError
from nnda.files import file_digest, write_json
from nnda.study.checksums import read_table, write_checksums
from nnda.study.plan import STUDY_FORMAT, STUDY_FORMAT_VERSION
from nnda.study.results import FORMAT_VERSION, SUMMARY_FORMAT, TIMING_FORMAT
from nnda.study.runner import MANIFEST
from nnda.study.timing import join_timing
from nnda.version import __version__

FINGERPRINT = "0" * 64
TABLES = ("timing.parquet", "results.parquet")


def tiny_study_dir(root: Path) -> Path:
    """``root / "study"``: a finished study directory of no job kind (its report has no section) whose
    ``checksums.json`` lists a timing and a results table, as a study writes them."""
    out = root / "study"
    out.mkdir(parents=True)
    write_json(out / MANIFEST, {"format": STUDY_FORMAT, "format_version": STUDY_FORMAT_VERSION,
                                "nnda_version": __version__, "fingerprint": FINGERPRINT, "study": {"name": "tiny"},
                                "kinds": [], "jobs": 0})
    write_json(out / "summary.json", {"format": SUMMARY_FORMAT, "format_version": FORMAT_VERSION, "study": "tiny",
                                      "fingerprint": FINGERPRINT})
    write_json(out / "timing.json", {"format": TIMING_FORMAT, "format_version": FORMAT_VERSION,
                                     "fingerprint": FINGERPRINT})
    pq.write_table(pa.table({"scenario": ["one"], "tracker": ["gnn"], "time_per_scan_s": [[0.001, 0.002]]}),
                   out / "timing.parquet")
    pq.write_table(pa.table({"scenario": ["one", "one"], "tracker": ["gnn", "gnn"], "run": [0, 1]}),
                   out / "results.parquet")
    write_checksums(out, ["summary.json", "timing.json", *TABLES], FINGERPRINT)
    return out


def recorded(out: Path, change) -> None:
    """Apply ``change`` to ``checksums.json``'s parsed content and write it back."""
    sums = json.loads((out / "checksums.json").read_text())
    change(sums)
    (out / "checksums.json").write_text(json.dumps(sums))


def rechecksum(out: Path, name: str) -> None:
    """Record ``name``'s present digest, as if the study had written the file as it is now."""
    recorded(out, lambda s: s["sha256"].update({name: file_digest(out / name)}))


def _flip_footer(path: Path) -> None:
    """Invert the first byte of the file's Thrift footer (its length is the 4 bytes before the closing "PAR1"):
    the reader cannot even open it, and says so on two lines."""
    data = bytearray(path.read_bytes())
    data[len(data) - 8 - int.from_bytes(data[-8:-4], "little")] ^= 0xFF
    path.write_bytes(bytes(data))


DAMAGE = {
    "footer": _flip_footer,
    "truncated": lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]),
    "not parquet": lambda p: p.write_bytes(b"PAR1 this is not a table PAR1"),
    "empty": lambda p: p.write_bytes(b""),
}


@pytest.fixture
def study(tmp_path) -> Path:
    return tiny_study_dir(tmp_path)


def test_the_hand_made_study_reports(study, nnda):
    outcome = nnda("report", "study", cwd=study.parent)
    assert outcome.code == 0, outcome.err
    assert (study / "report.html").is_file()


@pytest.mark.parametrize("name", TABLES)
@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_table_whose_checksum_was_updated_is_named(study, refused, name, damage):
    DAMAGE[damage](study / name)
    rechecksum(study, name)
    refused(study.parent, "report", "study",
            fragments=(f"study/{name}: not a readable Parquet table (", "run the study again with --resume"))


@pytest.mark.parametrize("name", TABLES)
def test_a_damaged_table_with_its_old_checksum_is_named(study, refused, name):
    _flip_footer(study / name)
    refused(study.parent, "report", "study", fragments=(f"study/{name}: corrupt or edited",))


def test_the_readers_message_is_kept_on_one_line(study):
    _flip_footer(study / "timing.parquet")
    rechecksum(study, "timing.parquet")
    with pytest.raises(DatasetError) as err:
        read_table(study, "timing.parquet")
    assert "\n" not in str(err.value) and str(err.value).startswith(f"{study / 'timing.parquet'}: not a readable")
    with pytest.raises(OSError) as raw:  # what the reader says: a line break inside
        pq.read_table(study / "timing.parquet")
    assert "\n" in str(raw.value)


@pytest.mark.parametrize("edit, fragments", [
    (lambda out: recorded(out, lambda s: s.update(sha256=["timing.parquet"])),
     ("study/checksums.json: field 'sha256' must map each file's name to its SHA-256, got list",)),
    (lambda out: recorded(out, lambda s: s.pop("sha256")), ("study/checksums.json: field 'sha256' must map",)),
    (lambda out: (out / "checksums.json").write_text("{"), ("study/checksums.json: not valid JSON",)),
    (lambda out: write_json(out / MANIFEST, {**json.loads((out / MANIFEST).read_text()), "kinds": None}),
     ("study/study.json: field 'kinds' is missing or not of the form this nnda writes",)),
    (lambda out: write_json(out / MANIFEST, {k: v for k, v in json.loads((out / MANIFEST).read_text()).items()
                                             if k != "study"}), ("study/study.json: field 'study' is missing",)),
    (lambda out: (write_json(out / "summary.json", {"format": SUMMARY_FORMAT, "format_version": FORMAT_VERSION}),
                  rechecksum(out, "summary.json")),
     ("study: study.json, summary.json and timing.json come from different studies",)),
    (lambda out: (write_json(out / "summary.json", {"format": SUMMARY_FORMAT, "format_version": FORMAT_VERSION,
                                                    "fingerprint": FINGERPRINT, "trackers": [{}]}),
                  rechecksum(out, "summary.json")),
     ("study: summary.json or timing.json does not have the layout this nnda writes (KeyError: 'label')",)),
])
def test_damaged_study_documents_are_named(study, refused, edit, fragments):
    edit(study)
    refused(study.parent, "report", "study", fragments=fragments)


def test_timing_that_does_not_match_the_summary_is_named():
    doc = {"runs": [{"gospa": 1.0}, {"gospa": 2.0}]}
    assert join_timing(doc, {"runs": [{"seconds": 3.0}, {}]}) == {"runs": [{"gospa": 1.0, "seconds": 3.0},
                                                                           {"gospa": 2.0}]}
    with pytest.raises(DatasetError, match=r"timing\.json does not match summary\.json at runs: 3 timed entries for "
                                           r"2 results"):
        join_timing(doc, {"runs": [{}, {}, {"seconds": 1.0}]})


def test_one_report_as_a_user_runs_it(study):
    """The same refusal from a new process: exit status 2 and one line, no traceback."""
    DAMAGE["truncated"](study / "results.parquet")
    rechecksum(study, "results.parquet")
    assert_one_line_error(nnda_process("report", "study", cwd=study.parent),
                          "study/results.parquet: not a readable Parquet table")


# ----------------------------------------------------------------------------- a real study's tables

STUDY_TOML = """name = "tiny"
runs = 1
[trackers.gnn]
kind = "gnn"
[[scenarios]]
config = "tiny.toml"
"""


@pytest.mark.slow
def test_a_real_studys_damaged_tables_are_named(tmp_path):
    (tmp_path / "tiny.toml").write_text(TINY_TOML)
    (tmp_path / "study.toml").write_text(STUDY_TOML)
    done = nnda_process("run", "--study", "study.toml", "--out", "good", "--jobs", "1", cwd=tmp_path)
    assert done.code == 0, done.err
    cases = [("timing.parquet", "rechecksum", "study/timing.parquet: not a readable Parquet table"),
             ("results.parquet", "rechecksum", "study/results.parquet: not a readable Parquet table"),
             ("trajectories.parquet", "rechecksum", "study/trajectories.parquet: not a readable Parquet table"),
             ("timing.parquet", "unlisted", "study/timing.parquet: not among the files this study wrote"),
             ("results.parquet", "unlisted", "study/results.parquet: not among the files this study wrote")]
    for name, how, fragment in cases:
        study = tmp_path / "study"
        shutil.rmtree(study, ignore_errors=True)
        shutil.copytree(tmp_path / "good", study)
        DAMAGE["footer"](study / name)
        if how == "rechecksum":
            rechecksum(study, name)
        else:
            recorded(study, lambda s, name=name: s["sha256"].pop(name))
        assert_one_line_error(nnda_process("report", "study", cwd=tmp_path), fragment)
