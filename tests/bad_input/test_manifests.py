"""A manifest names files in its own directory only, and cannot turn its own checks off.

Every manifest reader (a dataset's ``scenario.json``, a collection's ``collection.json``, a study's
``checksums.json``, a frame set's ``manifest.json``) refuses an entry that is an absolute path, holds '..'
or a separator, or is a symbolic link leading out of the directory, with an error naming the manifest and the
entry, before anything is opened there: nothing outside is read or hashed. A dataset relabelled as an older
format (its digests or seal dropped, so fewer checks would run) is refused unless an nnda that wrote that
format wrote it.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_run import TINY
from test_study_files_corrupt import recorded, tiny_study_dir

from dataset_edits import as_format, edit_manifest
from nnda.data.dataset import collection_members, iter_datasets, read_dataset, write_collection
from nnda.data.frames import FramesConfig, read_frames, simulate, write_frames
from nnda.data.generator import generate_runs
from nnda.data.scenario import scenario_from_dict
from nnda.errors import DatasetError
from nnda.files import file_digest
from nnda.version import __version__

SECRET = b"outside the directory\n"


@pytest.fixture
def secret(tmp_path) -> Path:
    """A file outside every directory under test, whose digest no error may show."""
    path = tmp_path / "elsewhere" / "secret.bin"
    path.parent.mkdir()
    path.write_bytes(SECRET)
    return path


def _hides(secret: Path, text: str) -> None:
    assert file_digest(secret)[:8] not in text, text


# ----------------------------------------------------------------------------- frame sets

@pytest.fixture
def frames(tmp_path) -> Path:
    return write_frames(simulate(FramesConfig(rows=8, cols=8, frames=2, template_half=1), runs=1, seed=0),
                        tmp_path / "frames")


def _list_in_frames(frames: Path, name: str, digest: str) -> None:
    """The frame manifest lists ``name`` (with ``digest``) in place of truth.npy."""
    doc = json.loads((frames / "manifest.json").read_text())
    del doc["files"]["truth.npy"]
    doc["files"][name] = digest
    (frames / "manifest.json").write_text(json.dumps(doc))


@pytest.mark.parametrize("entry", ["../elsewhere/secret.bin", "{secret}", "sub/truth.npy", ".truth.npy", ".."])
def test_a_frame_manifest_entry_outside_its_directory_is_refused(frames, secret, entry):
    name = entry.format(secret=secret)
    _list_in_frames(frames, name, "0" * 64)  # a wrong digest: the old reader showed the file's own
    with pytest.raises(DatasetError) as err:
        read_frames(frames)
    text = str(err.value)
    assert text.startswith(f"{frames / 'manifest.json'}: lists the data file {name!r}, which is not a plain name "
                           f"in {frames}"), text
    _hides(secret, text)


def test_a_frame_file_linked_out_of_its_directory_is_refused(frames, tmp_path):
    outside = tmp_path / "elsewhere-truth.npy"
    shutil.move(frames / "truth.npy", outside)
    os.symlink(outside, frames / "truth.npy")  # the same bytes, the recorded digest matches: still refused
    with pytest.raises(DatasetError, match=r"manifest\.json: its data file 'truth\.npy' is a symbolic link that "
                                           r"leads outside .*frames; a manifest names files in its own directory"):
        read_frames(frames)


@pytest.mark.parametrize("files, message", [
    ({}, r"field 'files' lists \[\]; a frame set holds exactly \['background\.npy', 'frames\.npy'"),
    (["truth.npy"], r"field 'files' must map each data file's name to its SHA-256, got list"),
    ({"truth.npy": 7}, r"field 'files' must map each data file's name to its SHA-256, got dict"),
])
def test_a_frame_manifest_must_list_every_data_file(frames, files, message):
    doc = json.loads((frames / "manifest.json").read_text())
    (frames / "manifest.json").write_text(json.dumps({**doc, "files": files}))
    with pytest.raises(DatasetError, match=rf"manifest\.json: {message}"):
        read_frames(frames)


def test_an_intact_frame_set_reads(frames):
    assert read_frames(frames).frames.shape == (1, 2, 8, 8)


# ----------------------------------------------------------------------------- datasets

def relabelled(version: int):
    """An `edit_manifest` change: this nnda's manifest called format ``version``, the fields of later formats
    dropped (its digests, its seal) and its writer kept: what a hand edit that wants fewer checks does."""
    def change(doc: dict) -> None:
        as_format(version)(doc)
        doc["nnda_version"] = __version__
    return change


def written_by_old_nnda(version: int):
    """An `edit_manifest` change: the manifest as nnda 0.1.0, which wrote formats 1 to 3, wrote it."""
    def change(doc: dict) -> None:
        as_format(version)(doc)
        doc["nnda_version"] = "0.1.0"
    return change


def test_a_dataset_file_linked_out_of_its_directory_is_refused(tiny_dataset, tmp_path, refused):
    outside = tmp_path / "elsewhere.parquet"
    shutil.move(tiny_dataset / "truth.parquet", outside)
    os.symlink(outside, tiny_dataset / "truth.parquet")
    refused(tmp_path, "plot-scenario", "ds", "--out", "s.png",
            fragments=("ds/scenario.json: its data file 'truth.parquet' is a symbolic link that leads outside ds",))


@pytest.mark.parametrize("version", [1, 2, 3])
def test_a_dataset_relabelled_as_an_older_format_is_refused(tiny_dataset, tmp_path, refused, version):
    edit_manifest(tiny_dataset, relabelled(version))
    refused(tmp_path, "plot-scenario", "ds", "--out", "s.png",
            fragments=(f"ds/scenario.json: field 'format_version' is {version}, but field 'nnda_version' is "
                       f"{__version__!r}, which writes format version 4: a relabelled (downgraded) manifest",))


def test_a_relabel_cannot_hide_changed_data(tiny_dataset):
    """The way round the digests: change a value, drop the digests by calling the dataset format 2."""
    table = pq.read_table(tiny_dataset / "truth.parquet")
    vx = table.column("vx").to_numpy().copy()
    vx[0] += 50.0  # no check ties a truth velocity to anything else
    pq.write_table(table.set_column(table.schema.get_field_index("vx"), "vx", [vx]), tiny_dataset / "truth.parquet")
    with pytest.raises(DatasetError, match="corrupt file"):
        read_dataset(tiny_dataset)
    edit_manifest(tiny_dataset, relabelled(2))
    with pytest.raises(DatasetError, match="a relabelled \\(downgraded\\) manifest"):
        read_dataset(tiny_dataset)


@pytest.mark.parametrize("writer, message", [
    (None, r"field 'nnda_version' is None, not an nnda version; a format-2 manifest names the nnda that wrote it"),
    ("unknown", r"field 'nnda_version' is 'unknown', not an nnda version"),
    ("0.3.1", r"field 'format_version' is 2, but field 'nnda_version' is '0\.3\.1', which writes format version 4"),
])
def test_an_older_format_names_its_writer(tiny_dataset, writer, message):
    edit_manifest(tiny_dataset, lambda m: (relabelled(2)(m), m.update(nnda_version=writer)))
    with pytest.raises(DatasetError, match=rf"ds/scenario\.json: {message}"):
        read_dataset(tiny_dataset)


@pytest.mark.parametrize("version", [2, 3])
def test_a_dataset_written_by_an_nnda_of_that_format_still_reads(tiny_dataset, version):
    edit_manifest(tiny_dataset, written_by_old_nnda(version))
    assert read_dataset(tiny_dataset).seed == TINY["seed"]


def test_the_format_1_fixture_still_reads():
    ds = read_dataset(Path(__file__).parents[1] / "data" / "fixtures" / "dataset-v1")
    assert ds.detections.scan.size == 24


# ----------------------------------------------------------------------------- collections

@pytest.fixture
def collection(tmp_path) -> Path:
    runs = generate_runs(scenario_from_dict(TINY), range(2))
    return write_collection(((f"run-{d.run:04d}", d) for d in runs), tmp_path / "mc", "two tiny runs")


def test_a_collection_member_linked_out_of_the_collection_is_refused(collection, tmp_path):
    shutil.move(collection / "run-0001", tmp_path / "elsewhere-run")
    os.symlink(tmp_path / "elsewhere-run", collection / "run-0001")
    with pytest.raises(DatasetError, match=r"mc/collection\.json: its member 'run-0001' is a symbolic link that leads "
                                           r"outside .*mc"):
        collection_members(collection)
    with pytest.raises(DatasetError, match="symbolic link"):
        list(iter_datasets(collection))


@pytest.mark.parametrize("member", ["../ds", "{abs}", "run-0000/../run-0001", ".."])
def test_a_collection_member_outside_the_collection_is_refused(collection, tmp_path, member):
    name = member.format(abs=tmp_path / "ds")
    edit_manifest(collection, lambda m: m.update(members=["run-0000", name]), "collection.json")
    with pytest.raises(DatasetError, match=r"mc/collection\.json: member: .* cannot name a file"):
        collection_members(collection)


# ----------------------------------------------------------------------------- study directories

@pytest.mark.parametrize("entry", ["../elsewhere/secret.bin", "{secret}", "sub/x.parquet", ".."])
def test_a_study_checksum_entry_outside_the_study_is_refused(tmp_path, secret, refused, entry):
    study = tiny_study_dir(tmp_path)
    name = entry.format(secret=secret)
    recorded(study, lambda s: s["sha256"].update({name: "0" * 64}))
    outcome = refused(tmp_path, "report", "study",
                      fragments=(f"study/checksums.json: lists the file {name!r}, which is not a plain name in "
                                 f"study",))
    _hides(secret, outcome.err)


def test_a_study_file_linked_out_of_the_study_is_refused(tmp_path, refused):
    study = tiny_study_dir(tmp_path)
    shutil.move(study / "results.parquet", tmp_path / "elsewhere.parquet")
    os.symlink(tmp_path / "elsewhere.parquet", study / "results.parquet")
    refused(tmp_path, "report", "study",
            fragments=("study/checksums.json: its file 'results.parquet' is a symbolic link that leads outside "
                       "study",))


def test_nothing_outside_is_opened(frames, secret, monkeypatch):
    """The refusal comes before any file named by the manifest is opened."""
    _list_in_frames(frames, str(secret), file_digest(secret))
    opened = []
    real_open = open

    def spy(file, *args, **kwargs):
        opened.append(Path(file).resolve() if isinstance(file, (str, os.PathLike)) else file)
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr("builtins.open", spy)
    with pytest.raises(DatasetError):
        read_frames(frames)
    assert secret.resolve() not in opened
    np.testing.assert_equal(secret.read_bytes(), SECRET)
