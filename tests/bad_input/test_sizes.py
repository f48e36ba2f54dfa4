"""Sizes bounded before anything is allocated: a study too big for the machine is refused when it is planned
(naming the table, its sizes, the estimate, the limit and how to raise it), and the PHD trackers bound the
(component, contact) pairs of a scan with a warning and a count, as the contact trackers bound their tracks."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
from cli_run import assert_one_line_error, nnda_process

import nnda.app.study_commands as study_commands
from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Sensor
from nnda.errors import BoundWarning, ConfigError
from nnda.study.config import load_study, study_from_dict
from nnda.study.kinds import pedestrian, reentry, tbd
from nnda.study.kinds.base import MAX_MEMORY_GIB, human_bytes, study_table
from nnda.study.pedestrian import study_results as pedestrian_results
from nnda.study.plan import plan_study
from nnda.study.tbd_runs import study_results
from nnda.tracking.phd import gmphd
from nnda.tracking.phd.config import MAX_PAIRS
from nnda.tracking.registry import make_tracker

BILLION = "1000000000"
TRACKERS_ON_T3 = ("runs = {runs}\n[trackers.gnn]\nkind = \"gnn\"\n[filters.imm]\nkind = \"imm\"\n"
                  "[[scenarios]]\npreset = \"T3\"\n")
KINDS = {"reentry": reentry, "tbd": tbd, "pedestrian": pedestrian}


def estimate(study, table: str) -> float:
    """The largest part of a table's memory estimate, bytes."""
    return max(p.bytes for p in KINDS[table].memory_parts(study_table(study, table)))


@pytest.fixture
def captured(monkeypatch):
    """The studies the command line would run (`run_study` replaced: nothing runs, nothing is written)."""
    studies = []
    monkeypatch.setattr(study_commands, "run_study", lambda study, *args, **kwargs: studies.append(study))
    return studies


# ----------------------------------------------------------------------------- the study commands


def test_reentry_with_a_billion_runs_is_refused_at_once(tmp_path):
    """It asked numpy for 1.6 TiB and ended in a traceback; now: refused from the config's arithmetic."""
    start = time.perf_counter()
    outcome = nnda_process("reentry", "--out", "r", "--runs", BILLION, cwd=tmp_path)
    seconds = time.perf_counter() - start
    assert_one_line_error(outcome, "the shipped reentry.toml: [reentry]:", "runs = 1,000,000,000 x steps = 55",
                          "TiB", "above the limit of 4 GiB (max_memory_gib = 4)", "lower runs or steps",
                          "max_memory_gib in the [reentry] table", "--max-memory-gib")
    assert not (tmp_path / "r").exists()
    assert seconds < 30  # the interpreter's start and imports; the check itself is arithmetic (below)


def test_the_check_is_arithmetic_on_the_config():
    study = study_from_dict({"reentry": {"runs": 10**12}}, "s.toml")
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"s\.toml: \[reentry\]: the aggregation would need about [\d.]+ PiB"):
        plan_study(study, "s.toml")
    assert time.perf_counter() - start < 0.5


@pytest.mark.parametrize("args, fragments", [
    (("reentry", "--runs", BILLION), ("[reentry]", "runs = 1,000,000,000", "TiB")),
    (("tbd", "--runs", BILLION), ("the shipped tbd.toml: [tbd]: the aggregation", "ptcr-6.5: 1,000,000,000 runs x "
                                  "20 frames", "lower runs or scene.frames", "nnda run, nnda tbd")),
    (("pedestrian", "--runs", BILLION), ("[pedestrian]: the aggregation", "walk-test2: 1,000,000,000 runs x 45 scans",
                                         "bootstrap = 1,000 resamples", "lower runs, test4_runs, stress_runs or "
                                         "bootstrap", "nnda run, nnda pedestrian")),
    (("pedestrian", "test4", "--test4-runs", BILLION), ("walk-test4: 1,000,000,000 runs x 60 scans",)),
    (("reentry", "--max-memory-gib", "0.01"), ("[reentry]: a job would need about", "MiB",
                                               "above the limit of 10.2 MiB (max_memory_gib = 0.01)")),
])
def test_each_study_command_refuses_a_study_too_big(refused, tmp_path, args, fragments):
    refused(tmp_path, args[0], "--out", "out", *args[1:], fragments=("max_memory_gib", *fragments))


def test_tbd_with_huge_frames_is_refused(refused, tmp_path):
    """10,000 x 10,000 frames asked for hundreds of TiB; now the frame size is named."""
    (tmp_path / "big.toml").write_text("[scene]\nrows = 10000\ncols = 10000\n")
    refused(tmp_path, "tbd", "--out", "t", "--config", "big.toml",
            fragments=("big.toml: [tbd]: a job on exit-reentry would need about", "TiB",
                       "a block of 20 runs (chunk_runs = 25) of 50 frames (exit_reentry.frames) of 10,000 x "
                       "10,000 pixels (scene.rows x scene.cols)",
                       "lower scene.rows, scene.cols, exit_reentry.frames or chunk_runs", "--max-memory-gib"))


@pytest.mark.parametrize("text, fragments", [
    ("[reentry]\nruns = 1000000000\n", ("study.toml: [reentry]: the aggregation", "runs = 1,000,000,000")),
    ("[reentry]\nchunk_particles = 1000000000\n[[reentry.settings]]\nname = \"a\"\nsigma_r = 200.0\n"
     "sigma_eps = 0.017\nparticles = [100000000]\n",
     ("[reentry]: a job would need", "1,000,000,000 particles at once", "lower chunk_particles or particles")),
    ("[tbd]\nruns = 10\nfilters = [{name = \"apf\", particles = 1000000000}]\n",
     ("[tbd]: a job on", "1,000,000,000 particles' work", "lower chunk_runs or particles")),
    ("[pedestrian]\ntests = [\"test2\"]\nbootstrap = 1000000000\n",
     ("[pedestrian]: the aggregation", "bootstrap = 1,000,000,000 resamples")),
    ("[reentry]\nmax_memory_gib = 0.001\n", ("above the limit of 1.02 MiB (max_memory_gib = 0.001)",)),
    (TRACKERS_ON_T3.format(runs=1_000_000_000),
     ("study.toml: the aggregation would need about", "runs = 1,000,000,000 of each generated scenario, "
      "1 scenario(s) of up to 100 scans, 1 tracker(s), 1 filter(s)",
      "max_memory_gib at the top of the study file or --max-memory-gib (nnda run)")),
])
def test_a_study_file_too_big_is_refused_by_nnda_run(refused, tmp_path, text, fragments):
    (tmp_path / "study.toml").write_text(text)
    refused(tmp_path, "run", "--study", "study.toml", "--out", "out", fragments=fragments)


@pytest.mark.parametrize("value", ["0", "-1", "nan"])
def test_a_limit_must_be_positive(refused, tmp_path, value):
    (tmp_path / "study.toml").write_text("[reentry]\nruns = 10\n")
    refused(tmp_path, "run", "--study", "study.toml", "--out", "out", "--max-memory-gib", value,
            fragments=("--max-memory-gib", "GiB"))


# ----------------------------------------------------------------------------- the limit, raised


def test_the_flag_raises_the_limit_of_a_shipped_study_at_the_boundary(nnda, tmp_path, captured):
    """Just below the estimate the study is refused when planned; just above it is planned (nothing runs)."""
    gib = estimate(study_commands.shipped_study("reentry", {})[0], "reentry") / 2**30
    for factor in (0.999, 1.001):
        assert nnda("reentry", "--out", "r", "--max-memory-gib", f"{gib * factor:.9f}", cwd=tmp_path).code == 0
    below, above = captured
    assert below.reentry.max_memory_gib == pytest.approx(gib * 0.999)
    with pytest.raises(ConfigError, match=r"\[reentry\]: a job would need about 246 MiB .* above the limit of 246 MiB"):
        plan_study(below, "reentry")
    assert above.reentry.max_memory_gib == pytest.approx(gib * 1.001)
    plan_study(above, "reentry")  # planned, nothing allocated


@pytest.mark.parametrize("command, args", [("reentry", ("--runs", BILLION)), ("tbd", ("--runs", BILLION)),
                                           ("pedestrian", ("--runs", BILLION))])
def test_the_flag_lets_a_huge_study_be_planned(nnda, tmp_path, captured, command, args):
    assert nnda(command, "--out", "o", *args, "--max-memory-gib", "1e12", cwd=tmp_path).code == 0
    (study,) = captured
    assert getattr(study, command).max_memory_gib == 1e12
    if command == "reentry":  # one job per filter whatever the runs: planned at once, nothing allocated
        assert len(plan_study(study, command).jobs) == 20


def test_nnda_run_flag_sets_every_limit_of_the_study(nnda, tmp_path, captured):
    """--max-memory-gib sets the top-level limit (tracker and filter jobs) and each table's."""
    (tmp_path / "study.toml").write_text("max_memory_gib = 0.0001\n" + TRACKERS_ON_T3.format(runs=2) +
                                         "[reentry]\nruns = 1000000000\n[pedestrian]\ntests = [\"test1\"]\n"
                                         "beyond = false\n")
    with pytest.raises(ConfigError, match=r"study: the aggregation would need about 400 KiB .*max_memory_gib = 0.0001"):
        plan_study(load_study(tmp_path / "study.toml"))
    assert nnda("run", "--study", "study.toml", "--out", "o", "--max-memory-gib", "1e9", cwd=tmp_path).code == 0
    (study,) = captured
    assert study.max_memory_gib == study.reentry.max_memory_gib == study.pedestrian.max_memory_gib == 1e9
    assert study.reentry.runs == 10**9 and study.tbd is None
    assert len(plan_study(study, "study.toml").jobs) == 2 * 2 + 20 + 1


def test_the_table_field_raises_the_limit(tmp_path):
    (tmp_path / "big.toml").write_text("[tbd.scene]\nrows = 10000\ncols = 10000\n")
    with pytest.raises(ConfigError, match=r"\[tbd\]: a job on"):
        plan_study(load_study(tmp_path / "big.toml"))
    (tmp_path / "big.toml").write_text("[tbd]\nmax_memory_gib = 1e6\n[tbd.scene]\nrows = 10000\ncols = 10000\n")
    assert plan_study(load_study(tmp_path / "big.toml")).jobs  # planned: no frame drawn


def test_the_limit_changes_no_job_key_and_no_result():
    """The limit is not a setting of the results: the same jobs (keys) with or without it, and the results'
    config leaves it out."""
    for table in KINDS:
        plain = plan_study(study_from_dict({table: {}}))
        limited = plan_study(study_from_dict({table: {"max_memory_gib": 64.0}}))
        assert plain.fingerprint == limited.fingerprint, table
    limited = study_from_dict({"reentry": {"settings": [], "max_memory_gib": 64.0}, "tbd": {"max_memory_gib": 64.0},
                               "pedestrian": {"tests": ["test1"], "beyond": False, "max_memory_gib": 64.0}})
    configs = [reentry.results(study_table(limited, "reentry"), [])["config"],
               study_results(study_table(limited, "tbd"), [], None, 0.0)["config"],
               pedestrian_results(study_table(limited, "pedestrian"), {}, None)["config"]]
    assert all(c and "max_memory_gib" not in c for c in configs)


@pytest.mark.parametrize("name", ["reentry", "tbd", "pedestrian"])
def test_shipped_studies_are_far_below_the_default_limit(name):
    study = study_commands.shipped_study(name, {})[0]
    assert estimate(study, name) < MAX_MEMORY_GIB * 2**30 / 4
    plan_study(study, name)


def test_human_bytes():
    assert [human_bytes(b) for b in (512, 2048, 1.5 * 2**30, 1.63 * 2**40, 2.0**60)] == [
        "512 B", "2 KiB", "1.5 GiB", "1.63 TiB", "1.02e+03 PiB"]


# ----------------------------------------------------------------------------- the PHD trackers' bound


def polar(rng, n: int) -> np.ndarray:
    """``n`` contacts uniform in the default radar's coverage: [range m, azimuth rad]."""
    s = Sensor()
    return np.column_stack([rng.uniform(s.min_range_m, s.max_range_m, n), rng.uniform(-np.pi, np.pi, n)])


@pytest.fixture
def formed(monkeypatch):
    """The number of candidate pairs of every update (`gmphd.candidates` spied on)."""
    sizes = []
    original = gmphd.candidates

    def spy(z0, centre, half_width):
        j, i = original(z0, centre, half_width)
        sizes.append(len(j))
        return j, i

    monkeypatch.setattr(gmphd, "candidates", spy)
    return sizes


@pytest.mark.parametrize("name", ["gmphd", "ekphd", "ukphd", "cphd", "fusion-central"])
def test_phd_pairs_are_bounded_with_one_warning_and_a_count(name, formed):
    """Every contact of a scan is a newborn at the next: two dense scans would pair every newborn with the
    contacts in its window; max_pairs leaves the lightest components out of that update."""
    rng = np.random.default_rng(0)
    tracker = make_tracker(name, Sensor(), {"max_pairs": 2_000})
    tracker.step(Scan(1, 2.0, polar(rng, 600)))
    assert tracker.n_dropped_components == 0
    with pytest.warns(BoundWarning, match=r"would form [\d,]+ candidate pairs, above the bound of 2,000; the "
                                          r"[\d,]+ lightest components were left out .*config field max_pairs"):
        tracker.step(Scan(2, 4.0, polar(rng, 600)))
    dropped, pairs = tracker.n_dropped_components, tracker.n_dropped_pairs
    assert 0 < dropped <= 600 and pairs > 0
    assert max(formed) <= 2_000
    with warnings.catch_warnings():
        warnings.simplefilter("error", BoundWarning)  # later cases of the run are only counted
        for k in (3, 4):
            tracker.step(Scan(k, 2.0 * k, polar(rng, 600)))
    assert tracker.n_dropped_components > dropped and tracker.n_dropped_pairs > pairs
    assert max(formed) <= 2_000
    tracker.reset()
    assert tracker.n_dropped_components == tracker.n_dropped_pairs == 0
    tracker.step(Scan(1, 2.0, polar(rng, 600)))
    with pytest.warns(BoundWarning, match="max_pairs"):  # a new run warns again
        tracker.step(Scan(2, 4.0, polar(rng, 600)))


def test_the_heaviest_components_are_kept():
    """A target's component outweighs the clutter's newborns: it keeps its pairs when the bound bites."""
    rng = np.random.default_rng(1)
    sensor = Sensor()
    tracker = make_tracker("ekphd", sensor, {"max_pairs": 500})
    target = np.array([[15_000.0, 0.3]])
    with pytest.warns(BoundWarning):
        for k in range(1, 6):
            tracker.step(Scan(k, 2.0 * k, np.vstack([target, polar(rng, 300)])))
    assert tracker.n_dropped_components > 0
    heaviest = np.argmax(tracker.mixture.weights)
    x, y = tracker.mixture.means[heaviest, [0, 2]]
    assert tracker.mixture.weights[heaviest] > 0.5
    assert np.hypot(x - 15_000 * np.sin(0.3), y - 15_000 * np.cos(0.3)) < 300


@pytest.mark.parametrize("name", ["fusion-merge", "fusion-aa", "fusion-gci"])
def test_fusion_trackers_bound_their_local_filters(name):
    rng = np.random.default_rng(2)
    tracker = make_tracker(name, [Sensor(name="a"), Sensor(name="b", x_m=1_000.0)], {"max_pairs": 2_000})
    with pytest.warns(BoundWarning) as caught:
        for k in range(1, 5):
            tracker.step(Scan(k, 2.0 * k, polar(rng, 600), sensor=(k - 1) % 2))
    messages = [str(w.message) for w in caught if issubclass(w.category, BoundWarning)]
    assert len(messages) == 1 and f"{name} (the local filter of sensor" in messages[0], messages
    assert tracker.n_dropped_components == sum(f.n_dropped_components for f in tracker.local) > 0
    assert tracker.n_dropped_pairs > 0


def test_the_default_bound_changes_no_result():
    """The default bound is far above a shipped scene's scans: the same tracks as with no bound, no warning."""
    ds = generate(PRESETS["S2"], seed=1)
    outputs = {}
    for bound in (MAX_PAIRS, None, 50):
        tracker = make_tracker("cphd", ds.scenario.sensor, {"max_pairs": bound})
        with warnings.catch_warnings():
            warnings.simplefilter("error" if bound != 50 else "ignore", BoundWarning)
            outputs[bound] = [tracker.step(scan) for scan in ds.scans()]
        assert (tracker.n_dropped_components > 0) == (bound == 50)
    for a, b in zip(outputs[MAX_PAIRS], outputs[None], strict=True):
        np.testing.assert_array_equal(a.track_id, b.track_id)
        np.testing.assert_array_equal(a.state, b.state)
