"""`nnda import-detections` on files in other shapes than UTF-8 with commas: a repeated column name, bytes that are
not text in the encoding, ';' or tab separators with decimal commas. Each is read with the options that say so
(--delimiter, --decimal, --encoding) or refused with one error naming file, line and column and what to pass;
nothing is ever imported mangled."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_run import assert_one_line_error, nnda_process

from nnda.data.dataset import read_dataset
from nnda.data.detections_import import read_detections
from nnda.errors import ConfigError, DatasetError

COMMA = ("time,range,azimuth,sensor,target_id\n"
         "2,15012.5,0.502,radar,101\n2,21000.25,1.5,radar,\n4,15100.75,0.5125,radar,101\n")
SEMICOLON = ("time;range;azimuth;sensor;target_id\n"
             "2;15012,5;0,502;radar;101\n2;21000,25;1,5;radar;\n4;15100,75;0,5125;radar;101\n")
TRUTH = "time,target_id,x,y,vx,vy\n2,101,7200.5,13170.25,100.5,0\n4,101,7401,13170.25,100.5,0\n"


@pytest.fixture
def files(tmp_path):
    """The same detections and truth written with commas (plots.csv, truth.csv) and with ';' and decimal commas
    (semi.csv, semi-truth.csv); an earlier output at ``ds`` that a refusal must keep."""
    (tmp_path / "plots.csv").write_text(COMMA)
    (tmp_path / "truth.csv").write_text(TRUTH)
    (tmp_path / "semi.csv").write_text(SEMICOLON)
    (tmp_path / "semi-truth.csv").write_text(TRUTH.replace(",", ";").replace(".", ","))
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "earlier.txt").write_text("an earlier output\n")
    return tmp_path


def _imported(nnda, root, name, *args):
    outcome = nnda("import-detections", *args, "--out", name, "--sensor", "scan_period_s=2", cwd=root)
    assert outcome.code == 0, outcome.err
    return read_dataset(root / name)


def _same(a, b):
    for record in ("detections", "truth"):
        for field, values in vars(getattr(a, record)).items():
            np.testing.assert_array_equal(values, getattr(getattr(b, record), field), err_msg=f"{record}.{field}")
    assert [t.name for t in a.scenario.targets] == [t.name for t in b.scenario.targets]


# ----------------------------------------------------------------------------- a repeated column name

def test_a_repeated_column_name_is_refused_naming_it_and_its_positions(files, refused):
    (files / "dup.csv").write_text("time,range,azimuth,range\n2,15012.5,0.502,15000\n")
    refused(files, "import-detections", "dup.csv", "--out", "ds", "--overwrite",
            fragments=("dup.csv: line 1 (the header)", "repeated: 'range' in columns 2, 4", "rename or remove"))


def test_repeated_names_in_the_truth_file_and_under_a_mapping_are_refused_and_unread_copies_kept(files):
    (files / "t.csv").write_text("time,target_id,x,y,vx,vy,x\n2,101,7200,13170,100,0,1\n")
    with pytest.raises(DatasetError, match=r"t\.csv: line 1 \(the header\).*'x' in columns 3, 7"):
        read_detections(files / "plots.csv", truth=files / "t.csv", sensors=[{"scan_period_s": 2}])
    (files / "m.csv").write_text("t,range,azimuth,t\n2,15012.5,0.502,3\n")
    with pytest.raises(DatasetError, match="'t' in columns 1, 4"):
        read_detections(files / "m.csv", columns=["time=t"])
    # copies of a column nnda does not read (empty names of trailing commas, notes) are no harm
    (files / "notes.csv").write_text("time,range,azimuth,note,note,,\n2,15012.5,0.502,a,b,,\n")
    assert read_detections(files / "notes.csv").detections.scan.size == 1


# ----------------------------------------------------------------------------- text not in the encoding

def test_a_byte_not_utf8_in_a_label_is_refused_with_its_line_and_column(files, refused):
    (files / "enc.csv").write_bytes(b"time,range,azimuth,target_id\n2,15012.5,0.502,101\n4,15100,0.5,1\xff01\n")
    refused(files, "import-detections", "enc.csv", "--out", "ds", "--overwrite",
            fragments=("enc.csv: data row 2 (line 3), column 'target_id'", "byte 0xff is not UTF-8 text",
                       "--encoding latin-1", "iconv -f cp1252 -t utf-8 enc.csv"))


def test_the_line_counts_as_an_editor_does_and_the_header_is_named(files):
    # CRLF line endings, a blank line and a quoted cell over two lines before the bad byte: it is on line 6
    (files / "lines.csv").write_bytes(b'time,range,azimuth,note\r\n2,15012.5,0.502,"two\r\nlines"\r\n\r\n'
                                      b'4,15100,0.5,ok\r\n6,15200,0.5,caf\xe9\r\n')
    with pytest.raises(DatasetError, match=r"lines\.csv: data row 3 \(line 6\), column 'note': byte 0xe9"):
        read_detections(files / "lines.csv")
    (files / "head.csv").write_bytes(b"time,range,azim\xfcth\n2,15012.5,0.502\n")
    with pytest.raises(DatasetError, match=r"head\.csv: line 1 \(the header\), column 3: byte 0xfc is not UTF-8"):
        read_detections(files / "head.csv")


def test_the_encoding_option_reads_the_text_right(files, nnda):
    (files / "latin.csv").write_bytes(COMMA.replace("101", "K\xf6ln").encode("latin-1"))
    plain = _imported(nnda, files, "plain", "plots.csv")
    latin = _imported(nnda, files, "latin", "latin.csv", "--encoding", "latin-1")
    assert [t.name for t in latin.scenario.targets] == ["Köln"]
    np.testing.assert_array_equal(latin.detections.target_id, plain.detections.target_id)
    (files / "u16.csv").write_bytes(COMMA.encode("utf-16"))
    _same(_imported(nnda, files, "u16", "u16.csv", "--encoding", "utf-16"), plain)
    (files / "bom.csv").write_bytes(COMMA.encode("utf-8-sig"))
    _same(_imported(nnda, files, "bom", "bom.csv"), plain)


def test_utf16_without_the_option_and_an_unknown_encoding_are_refused(files, refused):
    (files / "u16.csv").write_bytes(COMMA.encode("utf-16"))
    refused(files, "import-detections", "u16.csv", "--out", "new",
            fragments=("u16.csv: line 1", "UTF-16 byte-order mark", "pass --encoding utf-16"))
    refused(files, "import-detections", "plots.csv", "--out", "new", "--encoding", "klingon",
            fragments=("--encoding 'klingon': unknown text encoding",))
    (files / "ascii.csv").write_bytes(COMMA.replace("101", "\xe9").encode("latin-1"))
    refused(files, "import-detections", "ascii.csv", "--out", "new", "--encoding", "ascii",
            fragments=("data row 1 (line 2), column 'target_id': byte 0xe9 is not ascii text",))


def test_parquet_text_columns_are_decoded_not_stored_as_bytes(files):
    table = pa.table({"time": [2.0, 4.0], "range": [15012.5, 15100.0], "azimuth": [0.502, 0.5],
                      "target_id": pa.array([b"101", b"102"], pa.binary())})
    pq.write_table(table, files / "bytes.parquet")
    ds = read_detections(files / "bytes.parquet")
    assert [t.name for t in ds.scenario.targets] == ["101", "102"]
    pq.write_table(table.set_column(3, "target_id", pa.array([b"101", b"1\xff2"], pa.binary())), files / "bad.parquet")
    with pytest.raises(DatasetError, match=r"data row 2 \(line 3\), column 'target_id': b'1\\xff2' is not UTF-8"):
        read_detections(files / "bad.parquet")


# ----------------------------------------------------------------------------- ';', tabs and decimal commas

def test_a_semicolon_file_is_refused_naming_the_dialect_and_options(files, refused):
    refused(files, "import-detections", "semi.csv", "--out", "ds", "--overwrite",
            fragments=("semi.csv", "separated by ';', not ','", "pass --delimiter ';' --decimal ','"))
    (files / "semi-points.csv").write_text(SEMICOLON.replace(",", "."))
    refused(files, "import-detections", "semi-points.csv", "--out", "new",
            fragments=("line 1 (the header) reads as one column", "pass --delimiter ';'"))
    (files / "tabs.csv").write_text(COMMA.replace(",", "\t"))
    refused(files, "import-detections", "tabs.csv", "--out", "new", fragments=("pass --delimiter '\\t'",))
    refused(files, "import-detections", "semi.csv", "--out", "new", "--delimiter", ";",
            fragments=("semi.csv: data row 1 (line 2), column 'range': '15012,5', not a number",
                       "pass --decimal ','"))
    refused(files, "import-detections", "plots.csv", "--out", "new", "--delimiter", ";",
            fragments=("separated by ',', not ';'", "pass --delimiter ','"))


def test_delimiter_and_decimal_options_import_the_same_numbers(files, nnda):
    plain = _imported(nnda, files, "plain", "plots.csv", "--truth", "truth.csv")
    semi = _imported(nnda, files, "semi", "semi.csv", "--truth", "semi-truth.csv", "--delimiter", ";",
                     "--decimal", ",")
    _same(semi, plain)
    assert 15012.5 in semi.detections.range.tolist() and 21000.25 in semi.detections.range.tolist()
    for sep, spellings in (("\t", ("\t", "\\t", "tab")), ("|", ("|",))):
        (files / "sep.csv").write_text(COMMA.replace(",", sep))
        (files / "sep-truth.csv").write_text(TRUTH.replace(",", sep))
        for i, spelling in enumerate(spellings):
            _same(_imported(nnda, files, f"sep{i}{sep}", "sep.csv", "--truth", "sep-truth.csv", "--delimiter",
                            spelling), plain)


def test_bad_dialect_options_are_refused(files, refused):
    refused(files, "import-detections", "plots.csv", "--out", "new", "--delimiter", ":",
            fragments=("--delimiter ':': unknown delimiter",))
    refused(files, "import-detections", "plots.csv", "--out", "new", "--decimal", "'",
            fragments=("--decimal \"'\": unknown decimal mark",))
    refused(files, "import-detections", "plots.csv", "--out", "new", "--decimal", ",",
            fragments=("--decimal ',' with --delimiter ','", "--delimiter ';'"))
    refused(files, "import-detections", "semi.csv", "--out", "new", "--delimiter", ";", "--decimal", ",",
            "--truth", "truth.csv", fragments=("truth truth.csv", "separated by ',', not ';'", "truth file alike"))
    with pytest.raises(ConfigError, match="not a text encoding|unknown text encoding"):
        read_detections(files / "plots.csv", encoding="rot13")


def test_decimal_commas_only_with_the_option_and_parquet_unaffected(files, nnda):
    (files / "mixed.csv").write_text(SEMICOLON.replace("15100,75", "15100.75"))
    with pytest.raises(DatasetError, match=r"data row 3 \(line 4\), column 'range': '15100.75'.*decimal commas only"):
        read_detections(files / "mixed.csv", delimiter=";", decimal=",", sensors=[{"scan_period_s": 2}])
    plain = read_detections(files / "plots.csv", sensors=[{"scan_period_s": 2}])
    pq.write_table(pa.table({"time": [2.0, 2.0, 4.0], "range": [15012.5, 21000.25, 15100.75],
                             "azimuth": ["0.502", "1.5", "0.5125"], "sensor": ["radar"] * 3,
                             "target_id": ["101", None, "101"]}), files / "plots.parquet")
    for options in ({}, {"delimiter": ";", "decimal": ",", "encoding": "latin-1"}):
        _same(read_detections(files / "plots.parquet", sensors=[{"scan_period_s": 2}], **options), plain)


def test_a_semicolon_file_as_a_user_meets_it(files):
    outcome = nnda_process("import-detections", "semi.csv", "--out", "new", cwd=files)
    assert_one_line_error(outcome, "semi.csv", "pass --delimiter ';' --decimal ','")
    assert not (files / "new").exists()


# ----------------------------------------------------------------------------- compressed files

def _compressed(path, suffix: str, data: bytes):
    """``data`` written compressed at ``path`` + ``suffix`` (.gz, .bz2 or .zst)."""
    import bz2
    import gzip

    out = path.with_name(path.name + suffix)
    if suffix == ".zst":
        with pa.output_stream(str(out), compression="zstd") as f:
            f.write(data)
    else:
        out.write_bytes(gzip.compress(data) if suffix == ".gz" else bz2.compress(data))
    return out.name


def test_compressed_csvs_import_as_the_plain_file(files, nnda):
    plain = _imported(nnda, files, "plain", "plots.csv", "--truth", "truth.csv")
    for suffix in (".gz", ".bz2", ".zst"):
        det = _compressed(files / "plots.csv", suffix, COMMA.encode())
        truth = _compressed(files / "truth.csv", suffix, TRUTH.encode())
        ds = _imported(nnda, files, f"c{suffix[1:]}", det, "--truth", truth)
        _same(ds, plain)
        assert ds.scenario.name == "plots"
    # the dialect options and the encoding apply to the decompressed text
    semi = _compressed(files / "semi.csv", ".gz", SEMICOLON.encode())
    _same(_imported(nnda, files, "semi", semi, "--truth", "semi-truth.csv", "--delimiter", ";", "--decimal", ","),
          plain)
    latin = _compressed(files / "latin.csv", ".bz2", COMMA.replace("101", "K\xf6ln").encode("latin-1"))
    assert [t.name for t in _imported(nnda, files, "latin", latin, "--encoding", "latin-1").scenario.targets] == [
        "Köln"]


def test_a_compressed_file_is_diagnosed_as_the_plain_one(files, refused):
    semi = _compressed(files / "semi.csv", ".gz", SEMICOLON.encode())
    refused(files, "import-detections", semi, "--out", "ds", "--overwrite",
            fragments=("semi.csv.gz", "separated by ';', not ','", "pass --delimiter ';' --decimal ','"))
    bad = _compressed(files / "enc.csv", ".zst",
                      b"time,range,azimuth,target_id\n2,15012.5,0.502,101\n4,15100,0.5,1\xff01\n")
    refused(files, "import-detections", bad, "--out", "ds", "--overwrite",
            fragments=("enc.csv.zst: data row 2 (line 3), column 'target_id'", "byte 0xff is not UTF-8 text",
                       "zstd -dc enc.csv.zst | iconv -f cp1252 -t utf-8 > enc-utf8.csv"))


def test_a_corrupt_or_mislabelled_compressed_file_is_refused_naming_it(files, refused):
    whole = (files / _compressed(files / "plots.csv", ".gz", COMMA.encode())).read_bytes()
    (files / "cut.csv.gz").write_bytes(whole[: len(whole) // 2])
    refused(files, "import-detections", "cut.csv.gz", "--out", "ds", "--overwrite",
            fragments=("detections cut.csv.gz: not readable as gzip-compressed CSV", "damaged or not gzip data",
                       "gzip -t cut.csv.gz"))
    (files / "text.csv.bz2").write_text(COMMA)
    refused(files, "import-detections", "plots.csv", "--truth", "text.csv.bz2", "--out", "ds", "--overwrite",
            fragments=("truth text.csv.bz2: not readable as bz2-compressed CSV", "bzip2 -t text.csv.bz2"))
    (files / "plots.parquet.gz").write_bytes(whole)
    refused(files, "import-detections", "plots.parquet.gz", "--out", "ds", "--overwrite",
            fragments=("plots.parquet.gz: a compressed Parquet file is not read",))
    refused(files, "import-detections", "cut.csv.lz", "--out", "ds", "--overwrite", fragments=("no such file",))
    (files / "plots.csv.xz").write_bytes(whole)
    refused(files, "import-detections", "plots.csv.xz", "--out", "ds", "--overwrite",
            fragments=("unknown file type '.xz'", ".csv.gz, .csv.bz2, .csv.zst"))
