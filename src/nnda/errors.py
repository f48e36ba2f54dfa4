"""Exceptions raised at nnda's boundaries. Each message says what was wrong and where."""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

Model = TypeVar("Model", bound=BaseModel)


class NndaError(Exception):
    """Base class of every error nnda raises on bad input."""


class ConfigError(NndaError, ValueError):
    """A configuration (scenario, study, tracker) failed validation."""


class DatasetError(NndaError, ValueError):
    """A dataset on disk is missing, corrupt, of another format version or schema."""


class ModelError(NndaError, ValueError):
    """A model file is missing, corrupt or of another format or feature version, or a model got bad input."""


class FilterError(NndaError, ValueError):
    """A filter got bad input (shape, non-finite value, invalid covariance) or lost positive definiteness."""


class TrackingError(NndaError, ValueError):
    """A tracker got a bad scan (time not increasing, non-finite contact, wrong shape) or config."""


class OutputError(NndaError, OSError):
    """An output could not be written (read-only or full disk, no permission, another writer holds it),
    or its path is unsafe (an input, inside an input, a file where a directory goes)."""


class BoundWarning(UserWarning):
    """A configured bound on work or memory cut something (new tracks, hypotheses, joint events).

    The results are still valid for the bounded method; the warning names the
    bound and the config field that raises it.
    """


def validated(model: type[Model], data: Any, source: str, what: str) -> Model:
    """``model.model_validate(data)``, or a ConfigError listing every problem with its field path.

    ``source`` names where the data came from (a file, a config section),
    ``what`` the kind of thing (scenario, study, gnn config).
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        lines = [f"{source}: invalid {what} ({exc.error_count()} problem(s))"]
        for err in exc.errors():
            where = ".".join(str(p) for p in err["loc"]) or "<top level>"
            lines.append(f"  - {where}: {err['msg']}")
        raise ConfigError("\n".join(lines)) from None
