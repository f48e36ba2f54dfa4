"""Study files: validation, path resolution, the default study, writing and reading back."""

from __future__ import annotations

from pathlib import Path

import pytest

from nnda.errors import ConfigError
from nnda.study.config import default_study, load_study, study_from_dict, study_to_toml
from nnda.study.kinds.base import study_table
from nnda.tracking.lifecycle import THESIS_LIFECYCLE
from nnda.tracking.neural import life5


def test_relative_paths_resolve_against_the_study_file(small_study, tmp_path):
    study = load_study(small_study)
    assert [s.config for s in study.scenarios] == [tmp_path / "scenarios/one.toml", tmp_path / "scenarios/two.toml"]
    assert study.trackers["gnn-tight"].params == {"gate": 6.0}
    assert (study.seed, study.runs, study.gospa_cutoff_m, study.confidence) == (5, 3, 1000.0, 0.95)


def test_written_study_reads_back_equal(tmp_path):
    study = default_study(tmp_path / "models/gd", tmp_path / "models/lm", tmp_path / "models/ext", runs=7, seed=3,
                          ablation=tmp_path / "models/ablation").resolved(tmp_path)
    text = study_to_toml(study, relative_to=tmp_path)
    assert 'gd = "models/gd"' in text  # paths under the file's directory are written relative to it
    (tmp_path / "s.toml").write_text(text)
    assert load_study(tmp_path / "s.toml") == study
    assert 'ablation = "models/ablation"' in text
    assert list(study.trackers) == ["mht", "nn-gd", "nn-seed", "nn-ext", "nn-life", "gnn", "jpda", "ekphd", "cphd"]
    assert study.trackers["nn-ext"].params == {"feature_set": "imm-innovation-9", "lifecycle": THESIS_LIFECYCLE}
    assert all(study.trackers[t].params["lifecycle"]["confirmation"] == "mn" for t in ("mht", "nn-seed", "gnn", "jpda"))
    assert study.trackers["nn-life"].params == {"feature_set": "imm-innovation-9", **life5()}
    assert study.scenarios[0].preset == "validation"


@pytest.mark.parametrize("data, message", [
    ({"trackers": {}, "scenarios": [{"preset": "S1"}]}, "name what to run: at least one of [trackers"),
    ({"trackers": {"a": {"kind": "gnn"}}, "scenarios": [{"preset": "S1", "path": "x"}]},
     "give exactly one of preset, config or path"),
    ({"trackers": {"a": {"kind": "nn", "model": "lm"}}, "scenarios": [{"preset": "S1"}]},
     "uses model 'lm', which [models] does not declare"),
    ({"trackers": {"bad name": {"kind": "gnn"}}, "scenarios": [{"preset": "S1"}]}, "String should match pattern"),
    ({"trackers": {"a": {"kind": "gnn"}}, "scenarios": [{"preset": "S1"}], "runs": 0}, "runs: Input should be greater"),
    ({"trackers": {"a": {"kind": "gnn", "colour": "red"}}, "scenarios": [{"preset": "S1"}]},
     "trackers.a.colour: Extra inputs are not permitted"),
    ({"trackers": {"a": {"kind": "gnn"}}, "scenarios": [{"preset": "S1"}], "ownership": "nearest"},
     "ownership: Input should be 'auto', 'contacts' or 'position'"),
    ({"trackers": {"a": {"kind": "gnn"}}, "scenarios": [{"preset": "S1", "suffix": "-x"}]},
     "suffix names a changed scenario: give changes too"),
])
def test_malformed_studies_name_the_field(data, message):
    with pytest.raises(ConfigError, match="invalid study") as err:
        study_from_dict(data, "s.toml")
    assert message in str(err.value) and str(err.value).startswith("s.toml")


def test_ownership_reads_back_and_enters_the_job_keys_only_when_not_auto(tmp_path):
    from nnda.study.plan import plan_study

    base = {"trackers": {"a": {"kind": "gnn"}}, "scenarios": [{"preset": "S4"}], "runs": 1}
    auto, position = study_from_dict(base), study_from_dict({**base, "ownership": "position"})
    assert auto.ownership == "auto"
    (tmp_path / "s.toml").write_text(study_to_toml(position))
    assert load_study(tmp_path / "s.toml") == position
    plans = plan_study(auto), plan_study(position)
    assert [j.spec.ownership for p in plans for j in p.jobs] == ["auto", "position"]
    assert plans[0].fingerprint != plans[1].fingerprint


def test_unreadable_study_files(tmp_path):
    with pytest.raises(ConfigError, match="no such study file"):
        load_study(tmp_path / "none.toml")
    (tmp_path / "bad.toml").write_text("name = [")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_study(tmp_path / "bad.toml")
    (tmp_path / "s.yaml").write_text("")
    with pytest.raises(ConfigError, match="unknown study file type"):
        load_study(Path(tmp_path / "s.yaml"))


@pytest.mark.parametrize("kind", ["reentry", "tbd", "pedestrian"])
def test_a_kinds_table_leaves_the_seed_to_the_study(kind):
    with pytest.raises(ConfigError, match=f"{kind}: seed and confidence are the study's"):
        study_from_dict({kind: {"seed": 3}}, "s.toml")
    study = study_from_dict({"seed": 3, "confidence": 0.9, kind: {}}, "s.toml")
    assert (study_table(study, kind).seed, study_table(study, kind).confidence) == (3, 0.9)


def test_a_study_of_every_kind_reads_back_from_its_toml(tmp_path):
    study = study_from_dict({"name": "all", "seed": 3, "runs": 2, "trackers": {"g": {"kind": "gnn"}},
                             "scenarios": [{"preset": "S1"}], "reentry": {"runs": 5},
                             "tbd": {"runs": 3, "ptcr_db": [7.0]}, "pedestrian": {"tests": ["test4"]}}, "s")
    (tmp_path / "s.toml").write_text(study_to_toml(study, relative_to=tmp_path))
    assert load_study(tmp_path / "s.toml") == study


def test_a_study_changes_a_preset_groups_scenarios(tmp_path):
    """``changes`` on a preset group: every member changed and renamed, as the clutter sweep's stored files spell it
    out; a change the scenario refuses, or one asked of datasets on disk, names the entry."""
    from nnda.data.scenario import load_scenario
    from nnda.study.plan import plan_study

    (tmp_path / "s.toml").write_text("""
runs = 1
[trackers.gnn]
kind = "gnn"
[[scenarios]]
preset = "validation"
suffix = "-c1000"
[scenarios.changes]
"clutter.count" = 1000
[[scenarios]]
preset = "S2"
""")
    study = load_study(tmp_path / "s.toml")
    (tmp_path / "back.toml").write_text(study_to_toml(study, relative_to=tmp_path))
    assert load_study(tmp_path / "back.toml") == study
    scenarios = plan_study(study).kinds["track"].scenarios
    assert [s.name for s in scenarios] == [f"S{i}-c1000" for i in range(1, 7)] + ["S2"]
    sweep = Path(__file__).resolve().parents[2] / "studies" / "clutter-sweep"
    for s in scenarios[:6]:
        stored = load_scenario(sweep / f"{s.name}.json")
        assert s.scenario.model_copy(update={"description": stored.description}) == stored
    for entry, message in ((' preset = "S1"\n[scenarios.changes]\n"clutter.count" = -1', "greater than or equal to 0"),
                           (' path = "data"\n[scenarios.changes]\n"clutter.count" = 5', "not to the datasets at")):
        (tmp_path / "bad.toml").write_text(f"[trackers.gnn]\nkind = \"gnn\"\n[[scenarios]]\n{entry}\n")
        (tmp_path / "data").mkdir(exist_ok=True)
        with pytest.raises(ConfigError, match=r"scenarios\[0\]") as err:
            plan_study(load_study(tmp_path / "bad.toml"))
        assert message in str(err.value)
