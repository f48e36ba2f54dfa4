"""A fair comparison: every tracker of a study fitted to the scenes with the same budget before it is compared.

A tracker study's ``tuning`` table::

    [tuning]
    trials = 20     # Optuna trials per tracker (nnda.study.tuning.search), the same for every tracker
    runs = 1        # tuning runs per scenario, drawn after the study's own runs (runs .. runs + this - 1)

adds, for every tracker ``<label>`` of the study, a tracker ``<label>-tuned``: the same kind with the config
`nnda.study.tuning.search` finds from ``<label>``'s params, minimising the mean GOSPA over the tuning runs of
every scenario. The tuning runs are generated from the same scenarios and seed as the study's runs but are
other draws (run indices after them), so no run that is scored was seen by the search; the search is seeded
by the study's seed, so planning the study again finds the same configs (and the same job keys: a resumed
study reuses its jobs). Default and tuned trackers then run side by side on the study's runs, and the
report's tables show both. Scenarios read from disk have no further runs to draw: a study with ``tuning``
refuses them.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, Field

from nnda.errors import ConfigError
from nnda.study.kinds.base import STRICT

#: the suffix of a tuned tracker's label
TUNED = "-tuned"


class TuningSpec(BaseModel):
    """A study's ``tuning`` table (module docstring)."""

    model_config = STRICT

    trials: Annotated[int, Field(ge=1, strict=True, description="Optuna trials per tracker")] = 20
    runs: Annotated[int, Field(ge=1, strict=True, description="tuning runs per scenario, after the study's runs")] = 1


def tuned_params(study, trackers, scenarios, where: str) -> list[tuple[str, dict]]:
    """(label, params) of each tracker's tuned twin (module docstring), in the study's tracker order.

    ``trackers`` are the study's `TrackerPlan`s, ``scenarios`` its `ScenarioPlan`s."""
    from nnda.study.tuning import search

    labels = {t.label for t in trackers}
    taken = sorted(t.label + TUNED for t in trackers if t.label + TUNED in labels)
    if taken:
        raise ConfigError(f"{where}: tuning adds a tracker '<label>{TUNED}' per tracker, but {', '.join(taken)} "
                          f"is already a tracker of the study: rename it")
    stored = [sc.name for sc in scenarios if sc.source.stored_runs is not None]
    if stored:
        raise ConfigError(f"{where}: tuning draws further runs of each scenario, but {', '.join(stored)} is read "
                          f"from disk and has no more: tune on generated scenarios (presets or configs), or remove "
                          f"[tuning]")
    spec = study.tuning
    datasets = [d for sc in scenarios for d in sc.source.load(sc.runs, spec.runs, study.seed)]
    return [(t.label + TUNED, search(datasets, t.kind, t.params, spec.trials, study.seed, study.gospa_cutoff_m,
                                     f"{where}: tracker {t.label!r}").best_params) for t in trackers]
