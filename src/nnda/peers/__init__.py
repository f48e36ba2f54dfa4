"""Stone Soup peers: its trackers on our data, our trackers on its data, our tracks in its types.

Stone Soup (``stonesoup`` on PyPI) is an optional extra: ``pip install
'nnda[peers]'``. Nothing here imports it at nnda import time; the modules
that need it (`nnda.peers.adapter`, `nnda.peers.trackers`,
`nnda.peers.importer`, `nnda.peers.export`) are imported on demand, after `require_stonesoup`
has turned a missing install into a ConfigError that names the extra.
"""

from __future__ import annotations

import importlib

from nnda.errors import ConfigError

#: what to install for the peers
EXTRA = "pip install 'nnda[peers]'"


def require_stonesoup(what: str) -> None:
    """Raise a ConfigError naming the extra when Stone Soup cannot be imported; ``what`` says who asked."""
    try:
        importlib.import_module("stonesoup")
    except ImportError as exc:
        raise ConfigError(f"{what} needs Stone Soup, which is not installed ({exc}); "
                          f"install the peers extra: {EXTRA}") from None
