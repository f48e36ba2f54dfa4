"""nnda: data association in radar multi-target tracking.

Subpackages follow the data flow (conventions.md): ``data`` (scenarios and
datasets) -> ``models`` (neural association) -> ``tracking`` (filters and
trackers) -> ``study`` (Monte Carlo comparison) -> ``reports``.
"""

import importlib
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("nnda")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"


def track(dataset, tracker, config=None, model=None):
    """Run one tracker on one dataset (a `nnda.data.dataset.Dataset` or a dataset directory) and return its
    track table, a pyarrow Table (`nnda.study.track.TRACK_SCHEMA`). ``config``: the tracker's params (a mapping
    or a .toml/.json file); ``model``: the model file of ``nn``. Imports the trackers only when called."""
    # resolved at call time, by name: every layer imports this root package (for __version__), so a static
    # import of the study here would read, to the layer contract, as each of them importing the study
    study_track = importlib.import_module("nnda.study.track")
    return study_track.track(dataset, tracker, config=config, model=model)
