"""nnda's Python API: the few calls a script needs, each a front to the library's own functions.

    import nnda
    ds = nnda.generate("S3", seed=0, run=0)                  # a Dataset of a preset (or a Scenario)
    ds = nnda.read_dataset("data/plots")                     # or one on disk (`nnda import-detections`)
    tracks = nnda.track(ds, "mht", config={"n_scan": 3})    # pyarrow Table, one row per track per scan
    late = nnda.track(ds, "mht", lag=3)                      # the fixed-lag table: each scan revised 3 scans on
    result = nnda.run_study("studies/harbour.toml", "out/harbour")   # a study file, run and reported

``nnda`` itself imports this module only when one of these names is first
used, so ``import nnda`` stays light.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa

from nnda.data import dataset as _dataset
from nnda.data.dataset import Dataset
from nnda.data.generator import generate as _generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Scenario
from nnda.errors import ConfigError

__all__ = ["generate", "read_dataset", "run_study", "track"]

#: what each kind of argument accepts, as the error message says it
_PATH = (str, os.PathLike)
_PATH_TEXT = "a path (str or pathlib.Path)"


def _argument(call: str, name: str, value: Any, types: tuple[type, ...], accepted: str) -> None:
    """ConfigError naming the call, the argument, the value and its type, and what is accepted, unless
    ``value`` is one of ``types`` (a bool is never taken for a number, nor an empty string for a name)."""
    if isinstance(value, str) and not value:
        raise ConfigError(f"nnda.{call}: argument {name!r} is an empty string; give {accepted}")
    if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
        shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
        raise ConfigError(f"nnda.{call}: argument {name!r} is {shown} of type {type(value).__name__}; give "
                          f"{accepted}")


def track(dataset: Dataset | str | Path, tracker: str, config: Mapping[str, Any] | str | Path | None = None,
          model: str | Path | None = None, lag: int = 0) -> pa.Table:
    """The track table (`nnda.study.track.TRACK_SCHEMA`) of ``tracker`` (a registered name) on ``dataset`` (a
    `Dataset` or a dataset directory), stepped exactly as a study job steps it; ``config``: the tracker's params
    (a mapping or a .toml/.json file), ``model``: the model file of ``nn``. With ``lag`` L > 0 the table of the
    fixed-lag output instead (`nnda.tracking.lag`: the same rows, each scan's tracks revised with the L scans
    after it: confirmations back-filled, states smoothed, MHT's decided contacts). A wrong argument is a
    ConfigError naming it; a config file's problems name the file."""
    from nnda.study.track import load, run_tracker, tracker_params  # the trackers load only when one runs
    from nnda.tracking.lag import checked_lag
    from nnda.tracking.registry import check_config

    _argument("track", "dataset", dataset, (Dataset, *_PATH), f"a Dataset or a dataset directory as {_PATH_TEXT}")
    _argument("track", "tracker", tracker, (str,), "a registered tracker's name (str), e.g. 'gnn'")
    _argument("track", "config", config, (Mapping, *_PATH, type(None)),
              f"a mapping of the tracker's options, a .toml or .json file as {_PATH_TEXT}, or None")
    _argument("track", "model", model, (*_PATH, type(None)), f"the nn tracker's model file as {_PATH_TEXT}, or None")
    _argument("track", "lag", lag, (numbers.Integral,), "a whole number of scans >= 0")
    lag = checked_lag(lag, "nnda.track: argument 'lag'")
    params = tracker_params(config, model)
    where = f"tracker config {os.fspath(config)}" if isinstance(config, _PATH) else "tracker config"
    dataset = load(dataset)
    check_config(tracker, params, where, dataset.scenario.sensors)  # with the class of target they declare
    if lag:
        return lagged_runs(dataset, tracker, params, lag, score=False)[1].table
    return run_tracker(dataset, tracker, params, score=False).table


def lagged_runs(dataset: Dataset | str | Path, tracker: str, params: Mapping[str, Any], lag: int,
                cutoff_m: float | None = None, ownership: str = "auto", on_scan=None, score: bool = True):
    """``tracker`` with ``params`` on ``dataset`` as a study job with a lag ``lag`` > 0 steps it
    (`nnda.study.track_job.step_run`): its online `TrackRun` and its fixed-lag one (the revision's own time
    per scan as ``step_seconds``), each scored where the dataset has truth and ``score`` is true."""
    from threadpoolctl import threadpool_limits

    from nnda.study.metrics import DEFAULT_CUTOFF_M, run_metrics
    from nnda.study.track import TrackRun, detection_record, has_truth, load, targets_record, track_table
    from nnda.study.track_job import management_record, step_run
    from nnda.tracking.registry import make_tracker

    dataset = load(dataset)
    cutoff_m = DEFAULT_CUTOFF_M if cutoff_m is None else cutoff_m
    with threadpool_limits(1):
        stepped = make_tracker(tracker, dataset.scenario.sensors, dict(params))
        outputs, lagged, seconds, lag_seconds, _ = step_run(stepped, dataset, lag, on_scan)
        scored = score and has_truth(dataset)
        management, detection = management_record(stepped), detection_record(stepped)
        runs = tuple(TrackRun(tracker, o, track_table(dataset, o), t,
                              run_metrics(dataset, o, cutoff_m, ownership) if scored else None, management, detection,
                              targets_record(stepped))
                     for o, t in ((outputs, seconds), (lagged, lag_seconds)))
    return runs


def generate(scenario: Scenario | str, seed: int = 0, run: int = 0) -> Dataset:
    """Run ``run`` of ``scenario`` (a `Scenario` or a preset name, see ``nnda presets``) drawn with ``seed``: the
    same dataset ``nnda generate`` writes and a study's job sees."""
    _argument("generate", "scenario", scenario, (Scenario, str), "a Scenario or a preset name (str), e.g. 'S3'")
    if isinstance(scenario, str):
        if scenario not in PRESETS:
            raise ConfigError(f"unknown preset {scenario!r}; presets: {', '.join(PRESETS)}")
        scenario = PRESETS[scenario]
    return _generate(scenario, seed, run)


def read_dataset(path: str | Path) -> Dataset:
    """The dataset directory at ``path`` (`nnda.data.dataset.read_dataset`: every file checked)."""
    _argument("read_dataset", "path", path, _PATH, f"a dataset directory as {_PATH_TEXT}")
    return _dataset.read_dataset(path)


def run_study(study: str | Path, out: str | Path, resume: bool = False, jobs: int = 2, dask: str | None = None,
              overwrite: bool = False, report: bool = True) -> Path:
    """Run the study file ``study`` into directory ``out`` as ``nnda compare`` does (every input checked first;
    ``resume``, ``jobs`` local processes or a ``dask`` scheduler address) and, with ``report``, write its report;
    returns ``out``."""
    from nnda.reports.study_report import write_report
    from nnda.study.compare import compare
    from nnda.study.config import load_study

    _argument("run_study", "study", study, _PATH, f"a study file (.toml or .json) as {_PATH_TEXT}")
    _argument("run_study", "out", out, _PATH, f"the output directory as {_PATH_TEXT}")
    for name, value in (("resume", resume), ("overwrite", overwrite), ("report", report)):
        _argument("run_study", name, value, (bool,), "True or False")
    _argument("run_study", "jobs", jobs, (numbers.Integral,), "a whole number of local processes >= 1")
    if jobs < 1:
        raise ConfigError(f"nnda.run_study: argument 'jobs' is {jobs}; give a whole number of local processes >= 1")
    _argument("run_study", "dask", dask, (str, type(None)), "a Dask scheduler address (str), or None")
    compare(load_study(study), out, resume=resume, workers=int(jobs), dask=dask, where=str(study), overwrite=overwrite)
    if report:
        write_report(out)
    return Path(out)
