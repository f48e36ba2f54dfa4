"""A study's ``tuning`` table: every tracker also run as ``<label>-tuned``, its config searched on other draws of
the same scenarios with the same budget."""

from __future__ import annotations

import pyarrow.parquet as pq
import pytest

from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.errors import ConfigError
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.study.plan import plan_study

#: two targets flying at 320 m/s, faster than the default initiation window's v_max (200 m/s)
FAST = """
name = "fast"
duration_s = 40.0
[[targets]]
name = "A"
x_m = -4000.0
y_m = 10000.0
heading_deg = 90.0
speed_m_s = 320.0
segments = [{ duration_s = 40.0 }]
[[targets]]
name = "B"
x_m = 6000.0
y_m = -12000.0
heading_deg = 300.0
speed_m_s = 320.0
segments = [{ duration_s = 40.0 }]
[clutter]
count = 30
"""


def _study(root, tuning: str = "[tuning]\ntrials = 6\n", scenarios: str = '[[scenarios]]\nconfig = "fast.toml"\n'):
    (root / "fast.toml").write_text(FAST)
    study = root / "study.toml"
    study.write_text(f'name = "fair"\nruns = 1\n{tuning}[trackers.gnn]\nkind = "gnn"\n{scenarios}')
    return study


def test_every_tracker_gets_a_tuned_twin_that_beats_a_wrong_default(tmp_path):
    """The default window never starts a 320 m/s target; the twin's search, on runs the study does not score,
    raises v_max and tracks both targets on the scored run."""
    compare(load_study(_study(tmp_path)), tmp_path / "out", workers=1)
    res = pq.read_table(tmp_path / "out" / "results.parquet").to_pydict()
    assert res["tracker"] == ["gnn", "gnn-tuned"]
    default, tuned = (dict(zip(res, row)) for row in zip(*res.values()))
    assert (default["confirmed_tracks"], default["hit_rate"]) == (0, 0.0)
    assert tuned["confirmed_tracks"] == 2 and tuned["hit_rate"] > 90.0
    assert tuned["gospa"] < 0.5 * default["gospa"]
    twin = plan_study(load_study(tmp_path / "study.toml")).kinds["track"].trackers[1]
    assert twin.label == "gnn-tuned" and twin.params["lifecycle"]["v_max"] > 320.0


def test_the_plan_is_the_same_twice_and_its_jobs_are_keyed_by_the_tuned_config(tmp_path):
    study = load_study(_study(tmp_path))
    first, again = plan_study(study), plan_study(load_study(tmp_path / "study.toml"))
    assert [j.key for j in first.jobs] == [j.key for j in again.jobs]
    plain = plan_study(load_study(_study(tmp_path, tuning="")))
    assert len(first.jobs) == 2 * len(plain.jobs)
    assert first.jobs[0].key == plain.jobs[0].key  # the default tracker's job is the study's without tuning


def test_a_taken_label_and_a_scenario_on_disk_are_refused(tmp_path):
    study = _study(tmp_path)
    study.write_text(study.read_text() + '[trackers.gnn-tuned]\nkind = "gnn"\n')
    with pytest.raises(ConfigError, match="gnn-tuned is already a tracker"):
        plan_study(load_study(study))
    with pytest.raises(Exception, match="trials"):
        load_study(_study(tmp_path, tuning="[tuning]\ntrials = 0\n"))
    write_dataset(generate(PRESETS["S1"]), tmp_path / "rec")
    with pytest.raises(ConfigError, match="rec is read from disk and has no more"):
        plan_study(load_study(_study(tmp_path, scenarios='[[scenarios]]\npath = "rec"\nname = "rec"\n')))
