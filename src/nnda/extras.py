"""Optional dependencies: import one where it is needed, or say which extra of nnda installs it.

Tracking, importing data, studies and reports need only nnda's core; training the association network
needs ``nnda[train]`` (torch, scikit-learn), a Dask cluster ``nnda[dask]``, Stone Soup's trackers
``nnda[peers]``, the parameter search of ``nnda tune`` ``nnda[tune]``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from nnda.errors import NndaError

#: the extra that installs each optional top-level package
EXTRA = {"torch": "train", "sklearn": "train", "dask": "dask", "distributed": "dask", "stonesoup": "peers",
         "optuna": "tune"}


def require(module: str, purpose: str) -> ModuleType:
    """``import module`` (a dotted name), or an `NndaError` naming the purpose and the extra to install."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = EXTRA.get(top)
        hint = f'pip install "nnda[{extra}]"' if extra else f"pip install {top}"
        raise NndaError(f"{purpose} needs {top}, which is not installed here: {hint}") from exc
