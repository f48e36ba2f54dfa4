"""Fuzzing the study-file loader (`nnda.study.config.load_study`): random TOML-ish and JSON-ish documents, and
random mutations of nnda's own study files (src/nnda/studies/*.toml), in their text and in their structure. Either a
study loads or an nnda error (ConfigError, ...) says why; any other exception fails. Derandomized and bounded."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import nnda
from nnda.errors import NndaError
from nnda.study.config import load_study

FUZZ = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])
STUDIES = Path(nnda.__file__).parent / "studies"
STUDY_FILES = sorted(p.name for p in STUDIES.glob("*.toml"))
TEXTS = {name: (STUDIES / name).read_text() for name in STUDY_FILES}


def _keys(value, found: set[str]) -> set[str]:
    if isinstance(value, dict):
        for k, v in value.items():
            found.add(k)
            _keys(v, found)
    elif isinstance(value, list):
        for v in value:
            _keys(v, found)
    return found


#: every key of nnda's study files, so random documents name real fields often
KEYS = sorted(set().union(*(_keys(tomllib.loads(t), set()) for t in TEXTS.values())))
#: values that stress a validator: huge and non-finite numbers, odd text, paths that cannot exist
ODD_VALUES = [0, -1, 1, 2 ** 31, 2 ** 63, 10 ** 30, -(10 ** 400), 10 ** 400, 1e308, -1e-320, float("nan"), float("inf"),
              -float("inf"), "", " ", "\x00", "a\x00b", "../../..", "/", "x" * 300, "\udc80", "gnn", "validation",
              "S1", "harbour", True, False, None, [], {}, [None], [[]], {"": None}]
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-(2 ** 70), 2 ** 70), st.floats(), st.text(max_size=8),
                    st.sampled_from(range(len(ODD_VALUES))).map(ODD_VALUES.__getitem__))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.one_of(st.sampled_from(KEYS), st.text(max_size=6)), inner,
                                                 max_size=4)), max_leaves=12)
#: TOML-ish text: its punctuation, keys, values and line breaks
TOML_PIECES = ["=", " = ", "[", "]", "[[", "]]", "{", "}", ",", ".", '"', "'", "\n", "#", "1", "-1", "1e999", "nan",
               "inf", "true", "0.5", '"gnn"', '"x"', "[trackers.a]\nkind = ", "[[scenarios]]\npreset = ", "\\u0000",
               "\t"]
TOML_BITS = st.lists(st.one_of(st.sampled_from(KEYS), st.sampled_from(TOML_PIECES), st.text(max_size=4)),
                     max_size=40).map("".join)


@pytest.fixture(scope="module")
def studies(tmp_path_factory) -> Path:
    """A copy of nnda's study directory (their relative paths hold), where each case writes its document."""
    root = Path(shutil.copytree(STUDIES, tmp_path_factory.mktemp("studies") / "studies"))
    (root / "loop1").symlink_to("loop2")  # a symlink loop: a path through it cannot be resolved
    (root / "loop2").symlink_to("loop1")
    return root


def _load(path: Path, text: str | bytes) -> None:
    """``load_study`` of ``text`` saved at ``path``: an nnda error is an answer; any other exception propagates."""
    if isinstance(text, str):
        text = text.encode("utf-8", errors="surrogatepass")
    path.write_bytes(text)
    try:
        load_study(path)
    except NndaError as exc:
        event(f"refused: {type(exc).__name__}")
    else:
        event("loaded")


def _mutated(draw, value):
    """``value`` (a study's parsed data) with one random node deleted, replaced, added to or emptied."""
    if isinstance(value, (dict, list)) and value and draw(st.integers(0, 3)):
        keys = list(value) if isinstance(value, dict) else list(range(len(value)))
        key = draw(st.sampled_from(keys))
        copy = dict(value) if isinstance(value, dict) else list(value)
        copy[key] = _mutated(draw, value[key])
        return copy
    operation = draw(st.sampled_from(["replace", "delete", "add", "empty", "duplicate"]))
    if operation == "replace" or not isinstance(value, (dict, list)):
        return draw(VALUES)
    if operation == "empty":
        return type(value)()
    if isinstance(value, dict):
        copy = dict(value)
        if operation == "delete" and copy:
            del copy[draw(st.sampled_from(list(copy)))]
        else:
            copy[draw(st.one_of(st.sampled_from(KEYS), st.text(max_size=6)))] = draw(VALUES)
        return copy
    copy = list(value)
    if operation == "delete" and copy:
        del copy[draw(st.integers(0, len(copy) - 1))]
    elif operation == "duplicate" and copy:
        copy.append(copy[-1])
    else:
        copy.append(draw(VALUES))
    return copy


@FUZZ
@given(name=st.sampled_from(STUDY_FILES), data=st.data())
def test_mutated_study_structures_load_or_raise_an_nnda_error(studies, name, data):
    document = tomllib.loads(TEXTS[name])
    for _ in range(data.draw(st.integers(1, 3))):
        document = _mutated(data.draw, document)
    _load(studies / "fuzz.json", json.dumps(document, allow_nan=True))


#: paths a study may name that no file system can take, or that lead nowhere
ODD_PATHS = ["\x00", "a\x00b", "x" * 300, "/", "..", "", " ", "~", "loop1/x", "loop2", "\udc80", "nul\u0000.toml",
             "/proc/self/../x", "a" * 5000]
#: where a study names a path: (kind of place, how to put ``value`` there)
PATH_PLACES = {
    "scenario path": lambda d, v: d.setdefault("scenarios", []).append({"path": v}),
    "scenario config": lambda d, v: d.setdefault("scenarios", []).append({"config": v}),
    "model": lambda d, v: d.setdefault("models", {}).__setitem__("m", v),
    "ablation": lambda d, v: d.__setitem__("ablation", v),
}


@FUZZ
@given(name=st.sampled_from(STUDY_FILES), place=st.sampled_from(sorted(PATH_PLACES)),
       value=st.one_of(st.sampled_from(ODD_PATHS), st.text(max_size=12)), as_toml=st.booleans())
def test_odd_paths_in_a_study_load_or_raise_an_nnda_error(studies, name, place, value, as_toml):
    document = tomllib.loads(TEXTS[name])
    PATH_PLACES[place](document, value)
    if as_toml and "\udc80" not in value:
        _load(studies / "fuzz.toml", tomli_w.dumps(document))
    else:
        _load(studies / "fuzz.json", json.dumps(document))


@FUZZ
@given(name=st.sampled_from(STUDY_FILES), edits=st.lists(
    st.tuples(st.floats(0, 1), st.integers(0, 12), st.one_of(TOML_BITS, st.text(max_size=6))), min_size=1,
    max_size=3))
def test_edited_study_texts_load_or_raise_an_nnda_error(studies, name, edits):
    text = TEXTS[name]
    for where, cut, insert in edits:  # cut a few characters at a place, and put something else there
        at = int(where * len(text))
        text = text[:at] + insert + text[at + cut:]
    _load(studies / "fuzz.toml", text)


@FUZZ
@given(text=TOML_BITS)
def test_random_toml_load_or_raise_an_nnda_error(studies, text):
    _load(studies / "fuzz.toml", text)


@FUZZ
@given(document=st.one_of(VALUES, st.dictionaries(st.sampled_from(KEYS), VALUES, max_size=6)),
       raw=st.binary(max_size=40))
def test_random_json_and_bytes_load_or_raise_an_nnda_error(studies, document, raw):
    _load(studies / "fuzz.json", json.dumps(document, allow_nan=True))
    _load(studies / "fuzz.json", raw)
    _load(studies / "fuzz.toml", raw)


@pytest.mark.parametrize("value, fragment", [
    ("a\x00b", "path 'a\\x00b' holds a NUL character"),
    ("loop1/x", "a path of the study cannot be resolved (Symlink loop"),
])
def test_paths_the_fuzzing_found_are_refused_by_name(studies, value, fragment):
    document = tomllib.loads(TEXTS["harbour.toml"])
    document["ablation"] = value
    (studies / "found.json").write_text(json.dumps(document))
    with pytest.raises(NndaError) as refused:
        load_study(studies / "found.json")
    assert str(refused.value).startswith(f"{studies / 'found.json'}: ") and fragment in str(refused.value)
