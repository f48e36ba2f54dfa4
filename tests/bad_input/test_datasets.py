"""Damaged and implausible datasets and collections, as `nnda plot-scenario`, `nnda train` and `nnda evaluate`
read them, and the output of `nnda plot-scenario`.

Values are changed as another writer would have made them (`dataset_edits.rewrite_table` records the new
digest), so each case reaches the check it is about; a change without the digest is a "corrupt file".
"""

from __future__ import annotations

import math
import shutil

import numpy as np
import pyarrow as pa
import pytest
from cli_run import TINY, assert_one_line_error, nnda_process

from dataset_edits import as_format, edit_manifest, flip_byte, rewrite_table, set_value, snapshot
from nnda.data.dataset import read_dataset, write_collection
from nnda.data.generator import generate_runs
from nnda.data.scenario import scenario_from_dict

DET, TRUTH = "detections.parquet", "truth.parquet"


def test_flipped_bytes_inside_the_detections_are_a_corrupt_file(tmp_path, tiny_dataset, refused):
    f = tiny_dataset / DET
    for offset in range(100, 164):  # the probe: 64 bytes flipped inside the file
        flip_byte(f, offset)
    refused(tmp_path, "plot-scenario", "ds", "--out", "s.png",
            fragments=(f"{f.relative_to(tmp_path)}: corrupt file: its SHA-256 is", "the manifest recorded"))


def test_one_flipped_byte_in_the_truth_stops_training(tmp_path, tiny_dataset, refused):
    flip_byte(tiny_dataset / TRUTH, -40)
    refused(tmp_path, "train", "--data", "ds", "--out", "m", fragments=("ds/truth.parquet: corrupt file",))


def test_a_corrupt_file_as_a_user_meets_it(tmp_path, tiny_dataset):
    flip_byte(tiny_dataset / DET, 300)
    before = snapshot(tmp_path)
    outcome = nnda_process("plot-scenario", "ds", "--out", "s.png", cwd=tmp_path)
    assert_one_line_error(outcome, "ds/detections.parquet: corrupt file")
    assert snapshot(tmp_path) == before


def _shift(column: str, row: int, by: float):
    def change(table: pa.Table) -> pa.Table:
        return set_value(column, row, table.column(column)[row].as_py() + by)(table)
    return change


def _repeat_first_row(table: pa.Table) -> pa.Table:
    return pa.concat_tables([table.slice(0, 1), table.slice(0, 1), table.slice(2)])


def _swap_scans(table: pa.Table) -> pa.Table:
    scan = table.column("scan").to_numpy().copy()
    last = int(np.flatnonzero(scan == 1)[-1])  # the last row of scan 1 and the first of scan 2
    scan[last], scan[last + 1] = scan[last + 1], scan[last]
    return table.set_column(0, "scan", pa.array(scan, type=pa.int32()))


@pytest.mark.parametrize("name, change, fragments", [
    (DET, _shift("x", 3, 50.0), ("ds/detections.parquet: columns 'x', 'y' at row 3 are", "m from the point that "
                                 "columns 'range'", "from sensor 'radar' at (0, 0) m (tolerance")),
    (DET, set_value("azimuth", 2, 2 * math.pi), ("ds/detections.parquet: column 'azimuth' is 6.283185307179586 rad "
                                                 "at row 2, outside [0, 2 pi)",)),
    (DET, set_value("azimuth", 4, -0.25), ("column 'azimuth' is -0.25 rad at row 4, outside [0, 2 pi)",)),
    (DET, set_value("range", 1, -5000.0), ("ds/detections.parquet: column 'range' is -5000.0 m at row 1; a range "
                                           "must be positive",)),
    (DET, set_value("range", 6, 0.0), ("column 'range' is 0.0 m at row 6",)),
    (DET, set_value("y", 5, math.nan), ("ds/detections.parquet: column 'y' has a non-finite value at row 5",)),
    (TRUTH, set_value("vx", 1, math.inf), ("ds/truth.parquet: column 'vx' has a non-finite value at row 1",)),
    (DET, _swap_scans, ("ds/detections.parquet: column 'scan' is not in increasing order: 1 at row",
                        "follows 2")),
    (DET, _shift("time", 0, 0.5), ("ds/detections.parquet: column 'time' is 2.5 s at row 0, but scan 1 is at "
                                   "2.0 s in the scenario's scan schedule",)),
    (TRUTH, _repeat_first_row, ("ds/truth.parquet: rows 0 and 1 (scan, target_id) = (1, 0) then (1, 0)",
                                      "repeat a target's scan")),
    (DET, set_value("is_clutter", 0, True), ("columns 'is_clutter' and 'target_id' disagree at row 0",)),
])
def test_implausible_values_are_refused_naming_file_column_and_row(tmp_path, tiny_dataset, refused, name, change,
                                                                   fragments):
    rewrite_table(tiny_dataset, name, change)
    refused(tmp_path, "plot-scenario", "ds", "--out", "s.png", fragments=fragments)


def test_a_position_within_the_tolerance_is_accepted(tiny_dataset):
    rewrite_table(tiny_dataset, DET, _shift("x", 3, 1e-4))  # 0.1 mm, as another machine's rounding might differ
    assert read_dataset(tiny_dataset).detections.x.size > 3


@pytest.mark.parametrize("field, value, fragments", [
    ("seed", "abc", ("ds/scenario.json: field 'seed' is 'abc'; it must be a whole number >= 0",)),
    ("seed", 1.5, ("field 'seed' is 1.5",)),
    ("seed", -3, ("field 'seed' is -3",)),
    ("seed", True, ("field 'seed' is True",)),
    ("run", None, ("ds/scenario.json: field 'run' is None",)),
    ("n_detections", 9999, ("ds/scenario.json: field 'n_detections' is 9999, but the dataset holds",)),
    ("target_names", ["b"], ("field 'target_names' is ['b'], but the dataset holds ['a']",)),
    ("sha256", {"detections.parquet": "0" * 64}, ("ds/scenario.json: field 'sha256' must map detections.parquet and "
                                                  "truth.parquet to their SHA-256 digests",)),
    ("format_version", 5, ("field 'format_version' is 5; this nnda", "reads version 1 or 2 or 3 or 4 only")),
])
def test_hand_edited_manifests_are_refused(tmp_path, tiny_dataset, refused, field, value, fragments):
    edit_manifest(tiny_dataset, lambda m: m.update({field: value}))
    refused(tmp_path, "plot-scenario", "ds", "--out", "s.png", fragments=fragments)


def test_a_dataset_of_format_2_reads_without_digests(tiny_dataset):
    edit_manifest(tiny_dataset, as_format(2))
    assert read_dataset(tiny_dataset).seed == TINY["seed"]


@pytest.fixture
def collection(tmp_path):
    runs = generate_runs(scenario_from_dict(TINY), range(3))
    return write_collection(((f"run-{d.run:04d}", d) for d in runs), tmp_path / "mc", "three tiny runs")


def _set_members(members):
    return lambda m: m.update(members=members)


@pytest.mark.parametrize("damage, fragments", [
    (lambda c: shutil.rmtree(c / "run-0001"), ("mc: member(s) run-0001 listed in collection.json are missing",)),
    (lambda c: shutil.copytree(c / "run-0000", c / "run-0009"),
     ("mc: run-0009 not listed in collection.json; a collection holds exactly its members",)),
    (lambda c: (c / "notes.txt").write_text("x"), ("mc: notes.txt not listed in collection.json",)),
    (lambda c: edit_manifest(c, _set_members([]), "collection.json"),
     ("mc/collection.json: field 'members' is empty",)),
    (lambda c: edit_manifest(c, _set_members(["run-0000", "../ds"]), "collection.json"),
     ("mc/collection.json: member: '../ds' cannot name a file",)),
    (lambda c: edit_manifest(c, _set_members(["run-0000", "run-0001", "run-0002", "run-0000"]), "collection.json"),
     ("mc/collection.json: field 'members' lists run-0000 more than once",)),
    (lambda c: flip_byte(c / "run-0002" / DET, 150), ("mc/run-0002/detections.parquet: corrupt file",)),
])
def test_a_collection_holds_exactly_its_listed_members(tmp_path, collection, refused, damage, fragments):
    damage(collection)
    refused(tmp_path, "train", "--data", "mc", "--out", "m", fragments=fragments)


def test_hidden_entries_of_a_collection_are_ignored(collection):
    (collection / ".DS_Store").write_text("finder")
    assert [d.run for d in map(read_dataset, sorted(collection.glob("run-*")))] == [0, 1, 2]
    from nnda.data.dataset import iter_datasets
    assert len(list(iter_datasets(collection))) == 3


@pytest.mark.parametrize("out, extra, fragments", [
    ("figs", (), ("--out figs: is a directory; give the PNG file to write, e.g. figs/scenario.png",)),
    ("figs.png", (), ("--out figs.png: is a directory",)),
    ("s.jpg", (), ("--out s.jpg: unknown figure type '.jpg'; plot-scenario writes PNG",)),
    ("s", (), ("--out s: unknown figure type '(no suffix)'",)),
    ("old.png", (), ("old.png: already exists (pass --overwrite to replace it)",)),
    ("ds/s.png", ("--overwrite",), ("--out ds/s.png lies inside the input ds",)),
    ("figs", ("--overwrite",), ("--out figs: is a directory",)),
])
def test_plot_out_must_be_a_new_png_outside_the_dataset(tmp_path, tiny_dataset, refused, out, extra, fragments):
    (tmp_path / "figs").mkdir()
    (tmp_path / "figs.png").mkdir()
    (tmp_path / "old.png").write_bytes(b"mine")
    refused(tmp_path, "plot-scenario", "ds", "--out", out, *extra, fragments=fragments)
    assert not (tmp_path / "figs" / "figs.png").exists() and not (tmp_path / "figs.png.png").exists()


def test_plot_overwrite_replaces_a_file_and_writes_nothing_else(tmp_path, tiny_dataset, nnda):
    (tmp_path / "old.png").write_bytes(b"mine")
    done = nnda("plot-scenario", "ds", "--out", "old.png", "--overwrite", cwd=tmp_path)
    assert done.code == 0, done.err
    assert (tmp_path / "old.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "old.png"]
