"""The pair-feature sets a model can be trained on, by name (model files record the name)."""

from __future__ import annotations

from nnda.errors import ConfigError
from nnda.models.context import IMM_CONTEXT
from nnda.models.features import KINEMATIC, FeatureSet
from nnda.models.innovation import IMM_INNOVATION

FEATURE_SETS: dict[str, FeatureSet] = {fs.name: fs for fs in (KINEMATIC, IMM_INNOVATION, IMM_CONTEXT)}


def feature_set(name: str, where: str = "feature set") -> FeatureSet:
    """The registered feature set ``name``; ConfigError naming the choices otherwise."""
    try:
        return FEATURE_SETS[name]
    except KeyError:
        raise ConfigError(f"{where}: unknown feature set {name!r}; choose one of {', '.join(FEATURE_SETS)}") from None
