"""nnda: data association in radar multi-target tracking.

Subpackages, from the bottom layer up: ``data`` (scenarios, sensors and
datasets), ``filters`` (single-object estimation), ``models`` (the neural
association model), ``tracking`` (multi-target trackers), ``peers`` (Stone
Soup behind nnda's tracker protocol), ``study`` (studies: plans, jobs,
measures, statistics), ``reports`` (pages, tables, figures) and ``app``
(the command line and the Python API). The API's calls (`nnda.track`,
`nnda.generate`, `nnda.read_dataset`, `nnda.run_study`, and
`nnda.to_stonesoup`, `nnda.truth_to_stonesoup` for Stone Soup's metrics;
`nnda.app.api`) are loaded on first use.
"""

from nnda.version import __version__

_API = ("generate", "read_dataset", "run_study", "to_stonesoup", "track", "truth_to_stonesoup")


def __getattr__(name: str):
    """The API's calls, loaded when first asked for: importing any nnda module imports this package first, so
    importing the application layer here would load all of nnda for each of them."""
    if name in _API:
        from nnda.app import api

        return getattr(api, name)
    raise AttributeError(f"module 'nnda' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_API])


__all__ = ["__version__", *_API]
