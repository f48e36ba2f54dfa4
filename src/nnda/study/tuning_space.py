"""The search space of `nnda.study.tuning`: which config fields of a tracker are tuned, and over what range.

A dimension is a (config path, low, high, log) record (`Dimension`): ``path`` a dotted field of the
tracker's config ("motion.cv_sigma_q", "lifecycle.v_max", "gate"), searched on a log scale when ``log``.
`search_space` keeps the candidates (`CANDIDATES`) whose field the tracker's config has and holds a number in
the base config, never by the tracker's name: the contact trackers' IMM (``motion``: process noise and mode
switching), gate, initiation window (``lifecycle.v_min`` / ``v_max``) and the thresholds of the life cycle's
confirmation rule (M/N counts, the score rule's error probabilities, the adaptive rule's false-track rate,
the existence rule's thresholds); the PHD filters' motion noise, survival, detection, birth rate, a
numeric clutter rate and the extraction threshold. A combination a config refuses (v_min >= v_max, m > n)
is a pruned trial, not an error.
"""

from __future__ import annotations

import copy
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel


@dataclass(frozen=True)
class Dimension:
    """One tuned field: its dotted config ``path``, range [low, high] (the field's unit), searched on a log
    scale when ``log``, as an integer when ``integer``; ``when(config)`` tells whether the base config uses
    the field (None: whenever the field holds a number)."""

    path: str
    low: float
    high: float
    log: bool = False
    integer: bool = False
    when: Callable[[BaseModel], bool] | None = None


def _rule(*rules: str) -> Callable[[BaseModel], bool]:
    """True when the config's life cycle confirms by one of ``rules``."""
    return lambda config: config.lifecycle.confirmation in rules


#: every dimension a tracker may have; `search_space` keeps those its config has
CANDIDATES: tuple[Dimension, ...] = (
    # the contact trackers' IMM (`nnda.tracking.tracker.MotionConfig`): m/s^2, rad/s, probabilities per scan
    Dimension("motion.cv_sigma_q", 0.1, 50.0, log=True),
    Dimension("motion.ct_sigma_q", 0.1, 50.0, log=True),
    Dimension("motion.ct_sigma_omega", 1e-3, 0.5, log=True),
    Dimension("motion.p_cv_to_ct", 1e-3, 0.3, log=True),
    Dimension("motion.p_ct_to_cv", 1e-3, 0.5, log=True),
    # chi-square gate of 2 dof (4.6: P_G = 0.9; 60: every plausible contact), also the PHD pair gate
    Dimension("gate", 4.0, 60.0, log=True),
    Dimension("pd", 0.5, 0.99),
    # initiation window, m/s
    Dimension("lifecycle.v_min", 0.0, 150.0),
    Dimension("lifecycle.v_max", 100.0, 800.0),
    # the sanity limits of a confirmed track (m; expected clutter contacts in its gate)
    Dimension("lifecycle.max_position_sd_m", 500.0, 20_000.0, log=True),
    Dimension("lifecycle.max_gate_clutter", 0.5, 20.0, log=True),
    # the confirmation rule's thresholds
    Dimension("lifecycle.m", 1, 5, integer=True, when=_rule("mn")),
    Dimension("lifecycle.n", 2, 8, integer=True, when=_rule("mn")),
    Dimension("lifecycle.max_misses", 1, 8, integer=True, when=_rule("mn")),
    Dimension("lifecycle.false_confirmation", 1e-9, 1e-3, log=True, when=_rule("score")),
    Dimension("lifecycle.false_track_rate", 0.1, 50.0, log=True, when=_rule("adaptive")),
    Dimension("lifecycle.false_deletion", 1e-5, 0.1, log=True, when=_rule("score", "adaptive")),
    Dimension("lifecycle.existence_confirmation", 0.5, 0.99, when=_rule("existence")),
    Dimension("lifecycle.existence_deletion", 1e-3, 0.2, log=True, when=_rule("existence")),
    # the PHD filters (`nnda.tracking.phd.config`)
    Dimension("sigma_q", 0.1, 50.0, log=True),
    Dimension("sigma_omega", 1e-3, 0.5, log=True, when=lambda config: getattr(config, "motion", None) == "ct"),
    Dimension("ps", 0.9, 0.999),
    Dimension("birth.rate", 1e-3, 1.0, log=True),
    Dimension("clutter", 0.1, 500.0, log=True),
    Dimension("extraction_threshold", 0.2, 0.8),
)

_ABSENT = object()


def field_value(config: BaseModel, path: str) -> Any:
    """The value at dotted ``path`` of a validated config, or `_ABSENT` when a step is not a field."""
    value: Any = config
    for part in path.split("."):
        if not isinstance(value, BaseModel) or part not in type(value).model_fields:
            return _ABSENT
        value = getattr(value, part)
    return value


def search_space(config: BaseModel) -> tuple[Dimension, ...]:
    """The `CANDIDATES` a validated tracker config (the base of the search) has: the field exists, holds a
    real number (not None, not a rule's name such as clutter "local") and its ``when`` holds."""
    def tuned(d: Dimension) -> bool:
        value = field_value(config, d.path)
        number = isinstance(value, numbers.Real) and not isinstance(value, bool)
        return number and (d.when is None or d.when(config))

    return tuple(d for d in CANDIDATES if tuned(d))


def with_values(params: Mapping[str, Any], values: Mapping[str, Any]) -> dict:
    """``params`` (a tracker's params, nested mappings) with each dotted path of ``values`` set; the input is
    not changed."""
    out = copy.deepcopy(dict(params))
    for path, value in values.items():
        *parents, leaf = path.split(".")
        node = out
        for part in parents:
            child = node.get(part)
            node[part] = dict(child) if isinstance(child, Mapping) else {}
            node = node[part]
        node[leaf] = value
    return out
