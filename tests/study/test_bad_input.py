"""Bad studies fail with a clear message before any job runs, and write nothing."""

from __future__ import annotations

import json

import pytest

from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.errors import NndaError
from nnda.study.compare import compare
from nnda.study.config import load_study

GNN = '[trackers.gnn]\nkind = "gnn"\n'


def _study(tmp_path, body: str):
    path = tmp_path / "study.toml"
    path.write_text('name = "bad"\nruns = 1\n' + body)
    return load_study(path)


@pytest.fixture
def foreign(tmp_path):
    """A directory that is not an nnda dataset, and one whose manifest is of another format."""
    other = tmp_path / "other"
    other.mkdir()
    (other / "tracks.csv").write_text("t,x,y\n0,1,2\n")
    wrong = tmp_path / "wrong"
    write_dataset(generate(preset("T3"), seed=1), wrong)
    manifest = json.loads((wrong / "scenario.json").read_text())
    (wrong / "scenario.json").write_text(json.dumps({**manifest, "format": "acme.radar"}))
    return tmp_path


@pytest.mark.parametrize("body, message", [
    ('[trackers.x]\nkind = "telepathy"\n[[scenarios]]\npreset = "S1"\n',
     "tracker 'x': unknown tracker 'telepathy'; registered trackers: "),
    ('[trackers.gnn]\nkind = "gnn"\nparams = { gate = -1.0 }\n[[scenarios]]\npreset = "S1"\n',
     "tracker 'gnn': invalid gnn config (1 problem(s))\n  - gate: Input should be greater than 0"),
    ('[models]\nlm = "models/lm"\n' + GNN + '[[scenarios]]\npreset = "S1"\n', "model 'lm': "),
    (GNN + '[[scenarios]]\npreset = "S9"\n', "scenarios[0]: unknown preset 'S9'"),
    (GNN + '[[scenarios]]\npath = "other"\n', "scenarios[0]: "),
    (GNN + '[[scenarios]]\npath = "wrong"\n', "field 'format' is 'acme.radar', expected 'nnda.dataset'"),
    (GNN + '[[scenarios]]\npath = "nowhere"\n', "no such dataset or collection directory"),
    (GNN + '[[scenarios]]\nconfig = "nowhere.toml"\n', "scenarios[0]: "),
    (GNN + '[[scenarios]]\npreset = "S1"\n[[scenarios]]\npreset = "S1"\n', "scenario name(s) S1 appear more than once"),
])
def test_rejected_before_any_job(foreign, body, message):
    out = foreign / "out"
    with pytest.raises(NndaError) as err:
        compare(_study(foreign, body), out, where="study.toml")
    assert message in str(err.value) and str(err.value).startswith("study.toml: ")
    assert not out.exists()


def test_missing_model_and_foreign_dataset_messages_name_the_file(foreign):
    with pytest.raises(NndaError, match=r"/models/lm: no such model file"):
        compare(_study(foreign, '[models]\nlm = "models/lm"\n' + GNN + '[[scenarios]]\npreset = "S1"\n'), foreign / "o")
    with pytest.raises(NndaError, match=r"other/scenario.json: missing \(not an nnda dataset directory\?\)"):
        compare(_study(foreign, GNN + '[[scenarios]]\npath = "other"\n'), foreign / "o")

