"""Datasets on disk: round trip, byte determinism, atomic writes and refusals."""

from __future__ import annotations

import json
from dataclasses import fields

import numpy as np
import pyarrow as pa
import pytest

from dataset_edits import as_format, edit_manifest, flip_byte, rewrite_table
from nnda.data import dataset as dataset_module
from nnda.data.dataset import Detections, Truth, iter_datasets, read_dataset, write_collection, write_dataset
from nnda.data.generator import generate, generate_runs
from nnda.errors import DatasetError


def _files(path):
    return {p.relative_to(path).as_posix(): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def test_round_trip(tmp_path, small_scenario):
    ds = generate(small_scenario, seed=5, run=2)
    back = read_dataset(write_dataset(ds, tmp_path / "d"))
    assert back.scenario == ds.scenario and back.seed == 5 and back.run == 2
    for record in ("detections", "truth"):
        for f in fields(getattr(ds, record)):
            a, b = getattr(getattr(ds, record), f.name), getattr(getattr(back, record), f.name)
            np.testing.assert_array_equal(a, b)
            assert a.dtype == b.dtype or a.dtype.kind == b.dtype.kind


def test_same_seed_same_bytes_different_seed_differs(tmp_path, small_scenario):
    write_dataset(generate(small_scenario, seed=9), tmp_path / "a")
    write_dataset(generate(small_scenario, seed=9), tmp_path / "b")
    write_dataset(generate(small_scenario, seed=10), tmp_path / "c")
    a, b, c = (_files(tmp_path / n) for n in "abc")
    assert a == b
    assert a["detections.parquet"] != c["detections.parquet"]


def test_collection_round_trip(tmp_path, small_scenario):
    runs = list(generate_runs(small_scenario, range(3), seed=1))
    write_collection(((f"run-{d.run:04d}", d) for d in runs), tmp_path / "mc", "test")
    back = list(iter_datasets(tmp_path / "mc"))
    assert [d.run for d in back] == [0, 1, 2]
    np.testing.assert_array_equal(back[1].detections.range, runs[1].detections.range)


def test_scans_iterate_every_sweep_including_empty(small_scenario):
    sc = small_scenario.model_copy(update={"clutter": small_scenario.clutter.model_copy(update={"law": "none"})})
    ds = generate(sc, seed=1)
    scans = list(ds.scans())
    assert [s.index for s in scans] == list(range(1, 21))
    assert [s.time for s in scans] == [2.0 * k for k in range(1, 21)]
    assert sum(len(s.measurements) for s in scans) == ds.detections.scan.size
    assert len(scans[4].measurements) == 1  # target B missed in scans 4 and 5
    assert all(s.measurements.shape[1] == 2 for s in scans)


def test_failed_write_leaves_nothing(tmp_path, small_scenario, monkeypatch):
    ds = generate(small_scenario, seed=1)

    def boom(*_a, **_k):
        raise OSError("disk full")

    monkeypatch.setattr(dataset_module.pq, "write_table", boom)
    with pytest.raises(OSError, match="disk full"):
        write_dataset(ds, tmp_path / "d")
    assert list(tmp_path.iterdir()) == []


def test_failed_collection_leaves_nothing_and_keeps_old(tmp_path, small_scenario):
    write_dataset(generate(small_scenario, seed=1), tmp_path / "keep")
    before = _files(tmp_path / "keep")

    def members():
        yield "run-0000", generate(small_scenario, seed=1)
        raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError):
        write_collection(members(), tmp_path / "keep", "x", overwrite=True)
    assert _files(tmp_path / "keep") == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep"]


def test_existing_output_is_refused_unless_overwrite(tmp_path, small_scenario):
    ds = generate(small_scenario, seed=1)
    write_dataset(ds, tmp_path / "d")
    with pytest.raises(FileExistsError, match="already exists"):
        write_dataset(ds, tmp_path / "d")
    write_dataset(generate(small_scenario, seed=2), tmp_path / "d", overwrite=True)
    assert read_dataset(tmp_path / "d").seed == 2


@pytest.fixture
def written(tmp_path, small_scenario):
    return write_dataset(generate(small_scenario, seed=1), tmp_path / "d")


def test_truncated_parquet_is_a_corrupt_file(written):
    f = written / "detections.parquet"
    f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    with pytest.raises(DatasetError, match="detections.parquet: corrupt file: its SHA-256 is"):
        read_dataset(written)


def test_a_flipped_byte_in_either_data_file_is_a_corrupt_file(written):
    for name in ("truth.parquet", "detections.parquet"):
        flip_byte(written / name, 200)
        with pytest.raises(DatasetError, match=rf"{written / name}: corrupt file"):
            read_dataset(written)
        flip_byte(written / name, 200)
    read_dataset(written)


def test_unreadable_parquet_is_refused(written):
    rewrite_table(written, "truth.parquet", lambda t: t)
    (written / "detections.parquet").write_bytes(b"PAR1 not really")
    edit_manifest(written, as_format(2))  # no digests: the Parquet reader sees it
    with pytest.raises(DatasetError, match="detections.parquet: unreadable Parquet"):
        read_dataset(written)


def test_format_2_without_digests_still_reads(written):
    edit_manifest(written, as_format(2))
    assert read_dataset(written).seed == 1


def test_format_3_without_its_seal_still_reads_and_4_is_written_sealed(written):
    meta = json.loads((written / "scenario.json").read_text())
    assert meta["format_version"] == 4 and len(meta["manifest_sha256"]) == 64
    edit_manifest(written, as_format(3))
    assert read_dataset(written).seed == 1


@pytest.mark.parametrize("change, message", [
    (lambda m: m.update(seed=2), r"edited or corrupt \(field 'manifest_sha256' does not match"),
    (lambda m: m["scenario"]["targets"][0].update(speed_m_s=123.0), r"edited or corrupt"),
    (lambda m: m.update(format_version=2), r"field 'sha256' is written since format version 3, but field "
                                           r"'format_version' is 2: an edited manifest"),
    (lambda m: (m.update(format_version=3)), r"field 'manifest_sha256' is written since format version 4"),
])
def test_a_hand_edited_manifest_is_refused(written, change, message):
    edit_manifest(written, change, reseal=False)
    with pytest.raises(DatasetError, match=message):
        read_dataset(written)


def test_other_format_version_is_refused(written):
    meta = json.loads((written / "scenario.json").read_text())
    meta["format_version"] = 99
    (written / "scenario.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="scenario.json: field 'format_version' is 99"):
        read_dataset(written)


def test_foreign_json_is_refused(written):
    (written / "scenario.json").write_text(json.dumps({"format": "someone.else"}))
    with pytest.raises(DatasetError, match="field 'format' is 'someone.else'"):
        read_dataset(written)


def test_invalid_embedded_scenario_is_refused(written):
    meta = json.loads((written / "scenario.json").read_text())
    meta["scenario"]["targets"][0]["speed_m_s"] = -1
    (written / "scenario.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="targets.0.speed_m_s"):
        read_dataset(written)


@pytest.mark.parametrize("change, message", [
    (lambda t: t.drop_columns(["azimuth"]), "column 'azimuth' is missing"),
    (lambda t: t.set_column(0, "scan", pa.array(t.column("scan").to_numpy().astype("float64"))),
     "column 'scan' has type double"),
    (lambda t: t.append_column("colour", pa.array(np.zeros(t.num_rows))), "unexpected column"),
    (lambda t: t.set_column(
        2, "range", pa.array(np.where(np.arange(t.num_rows) == 3, np.nan, t.column("range").to_numpy()))),
     "column 'range' has a non-finite value at row 3"),
    (lambda t: t.set_column(0, "scan", pa.array(t.column("scan").to_numpy() + 100, type=pa.int32())),
     r"column 'scan' leaves the range 1..20: 101 at row 0"),
])
def test_bad_detection_tables_are_refused(written, change, message):
    rewrite_table(written, "detections.parquet", change)
    with pytest.raises(DatasetError, match=message):
        read_dataset(written)


def test_missing_files_are_named(tmp_path, written):
    (written / "truth.parquet").unlink()
    with pytest.raises(DatasetError, match="truth.parquet: missing"):
        read_dataset(written)
    with pytest.raises(DatasetError, match="no such dataset directory"):
        read_dataset(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(DatasetError, match="scenario.json: missing"):
        read_dataset(tmp_path / "empty")


def test_record_fields_match_the_schemas():
    assert [f.name for f in fields(Detections)] == dataset_module.DETECTIONS_SCHEMA.names
    assert [f.name for f in fields(Truth)] == dataset_module.TRUTH_SCHEMA.names
