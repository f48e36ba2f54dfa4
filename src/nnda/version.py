"""The installed nnda's version (a shared leaf: every layer records it in what it writes)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("nnda")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"
