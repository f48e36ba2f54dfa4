"""nnda: data association in radar multi-target tracking.

Subpackages follow the data flow (conventions.md): ``data`` (scenarios and
datasets) -> ``models`` (neural association) -> ``tracking`` (filters and
trackers) -> ``study`` (Monte Carlo comparison) -> ``reports``.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("nnda")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"
