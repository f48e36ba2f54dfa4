"""nnda's Python API: the few calls a script needs, each a front to the library's own functions.

    import nnda
    ds = nnda.generate("S3", seed=0, run=0)                  # a Dataset of a preset (or a Scenario)
    ds = nnda.read_dataset("data/plots")                     # or one on disk (`nnda import-detections`)
    tracks = nnda.track(ds, "mht", config={"n_scan": 3})    # pyarrow Table, one row per track per scan
    result = nnda.run_study("studies/harbour.toml", "out/harbour")   # a study file, run and reported

``nnda`` itself imports this module only when one of these names is first
used, so ``import nnda`` stays light.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa

from nnda.data.dataset import Dataset, read_dataset
from nnda.data.generator import generate as _generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Scenario
from nnda.errors import ConfigError

__all__ = ["generate", "read_dataset", "run_study", "track"]


def track(dataset: Dataset | str | Path, tracker: str, config: Mapping[str, Any] | str | Path | None = None,
          model: str | Path | None = None) -> pa.Table:
    """The track table (`nnda.study.track.TRACK_SCHEMA`) of ``tracker`` (a registered name) on ``dataset`` (a
    `Dataset` or a dataset directory), stepped exactly as a study job steps it; ``config``: the tracker's params
    (a mapping or a .toml/.json file), ``model``: the model file of ``nn``."""
    from nnda.study.track import run_tracker  # the trackers load only when one runs

    return run_tracker(dataset, tracker, config, model, score=False).table


def generate(scenario: Scenario | str, seed: int = 0, run: int = 0) -> Dataset:
    """Run ``run`` of ``scenario`` (a `Scenario` or a preset name, see ``nnda presets``) drawn with ``seed``: the
    same dataset ``nnda generate`` writes and a study's job sees."""
    if isinstance(scenario, str):
        if scenario not in PRESETS:
            raise ConfigError(f"unknown preset {scenario!r}; presets: {', '.join(PRESETS)}")
        scenario = PRESETS[scenario]
    return _generate(scenario, seed, run)


def run_study(study: str | Path, out: str | Path, resume: bool = False, jobs: int = 2, dask: str | None = None,
              overwrite: bool = False, report: bool = True) -> Path:
    """Run the study file ``study`` into directory ``out`` as ``nnda compare`` does (every input checked first;
    ``resume``, ``jobs`` local processes or a ``dask`` scheduler address) and, with ``report``, write its report;
    returns ``out``."""
    from nnda.reports.study_report import write_report
    from nnda.study.compare import compare
    from nnda.study.config import load_study

    compare(load_study(study), out, resume=resume, workers=jobs, dask=dask, where=str(study), overwrite=overwrite)
    if report:
        write_report(out)
    return Path(out)
