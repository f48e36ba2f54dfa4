"""The search space of `nnda.study.tuning`: which config fields of a tracker are tuned, and over what range.

A dimension is a (config path, low, high, log) record (`Dimension`): ``path`` a dotted field of the
tracker's config ("motion.cv_sigma_q", "lifecycle.v_max", "gate"), searched on a log scale when ``log``.
`search_space` keeps the candidates (`CANDIDATES`) whose field the tracker's config has and holds a number in
the base config, never by the tracker's name: the contact trackers' IMM (``motion``: process noise and mode
switching), gate, initiation window (``lifecycle.v_min`` / ``v_max``) and the thresholds of the life cycle's
confirmation rule (M/N counts, the score rule's error probabilities, the adaptive rule's false-track rate,
the existence rule's thresholds); the PHD filters' motion noise, survival, detection, birth rate, a
numeric clutter rate and the extraction threshold; with a sensor of asynchronous reports, the life cycle's
``report_gap_s``. A range that does not hold the base config's value (ships' speeds below the window's range
made for aircraft) is widened to four times beyond it on that side. A combination a config refuses
(v_min >= v_max, m > n) is a pruned trial, not an error.

Track continuation (``continuation_gate``) is not searched but kept at the base config's value: it acts only
where a target turns out of its track's gate, which a tuning half may never show. On 20 minutes of recorded
airliner traffic the best configs of six searches made no join on the tuning half (those with the threshold
held at 30 made two to four on the held-out half): the threshold was noise to the search (held-out GOSPA with
switching 2,020-2,156 m over three seeds with it searched, 1,935-2,129 m with it held at 30).
"""

from __future__ import annotations

import copy
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from pydantic import BaseModel


@dataclass(frozen=True)
class Dimension:
    """One tuned field: its dotted config ``path``, range [low, high] (the field's unit), searched on a log
    scale when ``log``, as an integer when ``integer``; ``when(config)`` tells whether the base config uses
    the field (None: whenever the field holds a number); ``reports``: only for data of asynchronous
    reports."""

    path: str
    low: float
    high: float
    log: bool = False
    integer: bool = False
    when: Callable[[BaseModel], bool] | None = None
    reports: bool = False

    def around(self, base: float) -> Dimension:
        """This dimension with its range widened to hold ``base``: to base / 4 below, 4 base above."""
        low = self.low if base >= self.low else (base / 4 if base > 0 else base)
        high = self.high if base <= self.high else 4 * base
        if self.integer:
            low, high = math.floor(low), math.ceil(high)
        return self if (low, high) == (self.low, self.high) else replace(self, low=low, high=high)


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
    # how long a track of asynchronous reports may go unreported (s)
    Dimension("lifecycle.report_gap_s", 10.0, 3_600.0, log=True, reports=True),
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


def search_space(config: BaseModel, reports: bool = False) -> tuple[Dimension, ...]:
    """The `CANDIDATES` a validated tracker config (the base of the search) has: the field exists, holds a
    real number (not None, not a rule's name such as clutter "local"), its ``when`` holds and, for a
    report-only dimension, the data has ``reports``; each range widened to hold the base value
    (`Dimension.around`)."""
    def tuned(d: Dimension) -> bool:
        value = field_value(config, d.path)
        number = isinstance(value, numbers.Real) and not isinstance(value, bool)
        return number and (d.when is None or d.when(config)) and (reports or not d.reports)

    return tuple(d.around(field_value(config, d.path)) for d in CANDIDATES if tuned(d))


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
