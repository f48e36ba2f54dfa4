"""A tracker's config fitted to one dataset by Optuna's TPE sampler (Bergstra et al. 2011): ``nnda tune``.

Usage sketch::

    result = tune(read_dataset("data/S3"), "gnn", trials=40, seed=0)   # TuneResult
    result.best_params      # the base params with the tuned fields set (a tracker config)
    result.scores           # {("default" | "tuned", "tuning" | "held-out"): {measure: value}}

**The split.** The first ``fraction`` of the scans (k = floor(fraction x n_scans)) are the tuning scans,
the rest the held-out ones; each is run as a dataset of its own (`scan_window`: the scans renumbered from
1, their times kept), so a tracker starts afresh on the held-out scans and nothing from them reaches the
search. Every trial runs on the tuning scans; the default (base) config and the best one are then scored on
both parts.

**The objective** (minimised):

* with truth: the mean over the tuning scans of GOSPA (alpha = 2, p = 2, cut-off c = ``cutoff_m``; the
  study's measure, `nnda.study.metrics`), confirmed tracks against the targets present; with a switching
  penalty gamma = ``switching_penalty_m`` > 0 (m), of GOSPA with that switching penalty (per scan
  (GOSPA^2 + gamma^2 n)^(1/2), n the scan's track switches of the GOSPA assignment: 1 for a target passed
  from one confirmed track to another, 0.5 between a track and none; after Garcia-Fernandez, Rahmathullah &
  Svensson (2020), `nnda.study.gospa.switching_counts`), which charges a track deleted and started again;
* without truth: innovation consistency, `innovation_consistency`: for every pair of consecutive reports
  of a track whose first report is confirmed and whose second used a contact, that contact's normalised
  innovation squared (NIS) against the tracker's own IMM prediction (its ``filters``, one per sensor) of
  the first report's [x, vx, y, vy] and covariance over the time between them; per confirmed track, the
  mean NIS over its updates divided by the measurement dimension (2), ideally 1; the objective is the
  mean over those tracks of |mean NIS / 2 - 1| plus the fraction of confirmed tracks deleted before the
  last scan (a track confirmed then lost). A run without any such update scores `NO_UPDATES`. It needs a
  tracker that reports its contacts and has per-sensor IMM filters (every contact tracker, not the PHD
  filters).

Trials are sampled by ``optuna.samplers.TPESampler(seed=seed)`` in one process; the first trial is the
base config's values (those inside the space's ranges), so the best is never worse than the default on the
tuning scans. A trial whose combination the config refuses (ConfigError: v_min >= v_max, m > n) is
pruned; the bounds a trial hits (`nnda.errors.BoundWarning`) are not shown, those of the default and best
configs' final runs are. Optuna is an extra (``nnda[tune]``), imported by `nnda.extras.require`.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from nnda.data.dataset import Dataset
from nnda.errors import BoundWarning, ConfigError
from nnda.study.metrics import DEFAULT_CUTOFF_M, ScoredRun, scored_metrics
from nnda.study.track import has_truth, run_tracker, track_covariances
from nnda.study.tuning_space import Dimension, field_value, search_space, with_values
from nnda.tracking.output import NO_CONTACT
from nnda.tracking.registry import check_config, make_tracker

#: the share of the scans tuned on by default
FRACTION = 0.5
#: scans each part of the split needs at least (a track confirms in 3)
MIN_WINDOW_SCANS = 5
#: the measures the report gives where the dataset has truth
MEASURES = ("gospa", "hit_rate", "lost_targets", "false_tracks")
#: those with a switching penalty: the objective (GOSPA with the search's switching penalty, mean over scans) first,
#: the track switches of the GOSPA assignment (the run's sum) last
SWITCHING_MEASURES = ("gospa_switching", *MEASURES, "track_switches")
#: the measures of innovation consistency (no truth): the objective and its parts
CONSISTENCY_MEASURES = ("objective", "nis_per_dim", "lost_fraction", "confirmed_tracks", "updates")
#: the no-truth objective of a run in which no confirmed track was updated (nothing to judge)
NO_UPDATES = 100.0
#: the measurement dimension of the NIS (range and azimuth, or x and y)
MEASUREMENT_DIM = 2


@dataclass(frozen=True)
class ScanWindow(Dataset):
    """Scans ``first``..``last`` of a dataset as a dataset of their own (`scan_window`)."""

    window_time: np.ndarray = dataclasses.field(default_factory=lambda: np.empty(0))
    window_sensor: np.ndarray = dataclasses.field(default_factory=lambda: np.empty(0, np.int32))

    @property
    def n_scans(self) -> int:
        return int(self.window_time.size)

    @property
    def scan_time(self) -> np.ndarray:
        return self.window_time

    @property
    def scan_sensor(self) -> np.ndarray:
        return self.window_sensor


def _rows(record, keep: np.ndarray, shift: int):
    """A `Detections` or `Truth` record's rows ``keep`` (bool mask), its scan numbers less ``shift``."""
    fields = {f.name: getattr(record, f.name) for f in dataclasses.fields(record)}
    cut = {name: None if a is None else np.asarray(a)[keep] for name, a in fields.items()}
    cut["scan"] = cut["scan"] - shift
    return type(record)(**cut)


def scan_window(dataset: Dataset, first: int, last: int) -> Dataset:
    """Scans ``first``..``last`` (1-based, inclusive) of ``dataset``, renumbered 1..last - first + 1, with
    their contacts and truth; the times (s) stay the dataset's, so a tracker sees the same intervals."""
    if not 1 <= first <= last <= dataset.n_scans:
        raise ConfigError(f"scans {first}..{last}: outside the dataset's 1..{dataset.n_scans}")
    det, truth = dataset.detections, dataset.truth
    shift = first - 1
    kept = {f.name: getattr(dataset, f.name) for f in dataclasses.fields(Dataset)}
    return ScanWindow(**{**kept, "detections": _rows(det, (det.scan >= first) & (det.scan <= last), shift),
                         "truth": _rows(truth, (truth.scan >= first) & (truth.scan <= last), shift)},
                      window_time=dataset.scan_time[first - 1:last].copy(),
                      window_sensor=dataset.scan_sensor[first - 1:last].copy())


def split_scans(n_scans: int, fraction: float) -> int:
    """k, the last tuning scan: floor(fraction x n_scans); ConfigError unless 0 < fraction < 1 and both parts
    hold `MIN_WINDOW_SCANS` scans."""
    if not (isinstance(fraction, (int, float)) and 0 < fraction < 1):
        raise ConfigError(f"--fraction {fraction!r}: the share of the scans tuned on must lie strictly between "
                          f"0 and 1 (e.g. 0.5); the rest are held out")
    k = math.floor(fraction * n_scans)
    if min(k, n_scans - k) < MIN_WINDOW_SCANS:
        raise ConfigError(f"--fraction {fraction}: splits the dataset's {n_scans} scans into {k} tuning and "
                          f"{n_scans - k} held-out scans; each part needs {MIN_WINDOW_SCANS} at least: choose a "
                          f"fraction nearer 0.5 or a longer dataset")
    return k


def innovation_consistency(dataset: Dataset, run, filters) -> dict[str, float]:
    """The no-truth objective of a tracker's run (module docstring) and its parts: ``nis_per_dim`` (the
    mean NIS / 2 over all updates counted), ``lost_fraction``, ``confirmed_tracks``, ``updates``.

    ``run`` is the `nnda.study.track.TrackRun` on ``dataset``, ``filters`` the tracker's IMM per sensor.
    One IMM prediction per sensor over all counted updates (no loop over tracks).
    """
    t = run.table
    scan, tid = t["scan"].to_numpy(), t["track_id"].to_numpy()
    status = t["status"].to_numpy(zero_copy_only=False).astype(str)
    confirmed, deleted = status == "confirmed", status == "deleted"
    order = np.lexsort((scan, tid))
    a, b = order[:-1], order[1:]
    pair = (tid[a] == tid[b]) & confirmed[a] & (t["contact"].to_numpy()[b] != NO_CONTACT)
    a, b = a[pair], b[pair]
    x = np.column_stack([t[c].to_numpy() for c in ("x", "vx", "y", "vy")])
    cov = track_covariances(t)
    when = t["time"].to_numpy()
    sensor = dataset.scan_sensor[scan[b] - 1]
    rows = t["detection"].to_numpy()[b]
    nis = np.empty(a.size)
    det = dataset.detections
    for s in np.unique(sensor):
        sel = sensor == s
        imm = filters[int(s)]
        z = (np.column_stack([det.range, det.azimuth]) if imm.polar else np.column_stack([det.x, det.y]))[rows[sel]]
        pred = imm.predict(imm.from_cv(x[a[sel]], cov[a[sel]]), when[b[sel]] - when[a[sel]])
        mp = pred.gating.measurement
        nu = imm.measurement.residual(z, mp.z)
        nis[sel] = np.einsum("pi,pij,pj->p", nu, mp.S_inv, nu)
    ever = np.unique(tid[confirmed])
    lost = np.unique(tid[deleted & (scan < dataset.n_scans)])
    lost_fraction = float(np.isin(ever, lost).mean()) if ever.size else 0.0
    if not nis.size:
        return {"objective": NO_UPDATES, "nis_per_dim": math.nan, "lost_fraction": lost_fraction,
                "confirmed_tracks": float(ever.size), "updates": 0.0}
    tracks, inverse = np.unique(tid[a], return_inverse=True)
    per_track = np.bincount(inverse, nis) / np.bincount(inverse) / MEASUREMENT_DIM
    return {"objective": float(np.abs(per_track - 1.0).mean() + lost_fraction),
            "nis_per_dim": float(nis.mean() / MEASUREMENT_DIM), "lost_fraction": lost_fraction,
            "confirmed_tracks": float(ever.size), "updates": float(nis.size)}


@dataclass(frozen=True)
class TrialRecord:
    """One trial: its number (0-based), state ("COMPLETE" or "PRUNED"), objective (None when pruned) and the
    values it tried, by config path."""

    number: int
    state: str
    objective: float | None
    params: dict[str, float | int]


@dataclass(frozen=True)
class TuneResult:
    """A search's outcome: what was tuned on what, every trial, the best values and the scores of the base
    (default) and tuned configs on the tuning and held-out scans (``scores[(config, part)][measure]``, the
    measures `MEASURES` with truth, else `CONSISTENCY_MEASURES`); ``seconds`` the search's wall time; ``kept``
    the fields of the space held at the base config's values."""

    tracker: str
    scenario: str
    n_scans: int
    tuning_scans: int
    truth: bool
    cutoff_m: float
    space: tuple[Dimension, ...]
    trials: tuple[TrialRecord, ...]
    best_trial: int
    best_values: dict[str, float | int]
    base_params: dict[str, Any]
    best_params: dict[str, Any]
    scores: dict[tuple[str, str], dict[str, float | None]]
    seconds: float
    kept: tuple[str, ...] = ()
    switching_penalty_m: float = 0.0

    @property
    def measures(self) -> tuple[str, ...]:
        """The keys of ``scores``' measures, the objective first (`score_measures`)."""
        return score_measures(self.truth, self.switching_penalty_m)


def score_measures(truth: bool, switching_penalty_m: float = 0.0) -> tuple[str, ...]:
    """The measures a search scores, the objective first: `MEASURES` with truth (`SWITCHING_MEASURES` with a
    switching penalty), else `CONSISTENCY_MEASURES`."""
    if not truth:
        return CONSISTENCY_MEASURES
    return SWITCHING_MEASURES if switching_penalty_m > 0 else MEASURES


def _scored(window: Dataset, tracker: str, params: Mapping[str, Any], cutoff_m: float,
            switching_penalty_m: float = 0.0) -> dict[str, float | None]:
    """The measures of one run of ``tracker`` with ``params`` on ``window``: `MEASURES` with truth
    (`SWITCHING_MEASURES` with a switching penalty > 0 m), else the innovation consistency's
    (`CONSISTENCY_MEASURES`); the first is the objective."""
    if switching_penalty_m > 0 and has_truth(window):
        run = run_tracker(window, tracker, params, cutoff_m=cutoff_m, score=False)
        scored = ScoredRun(window, run.outputs, cutoff_m)
        values = scored_metrics(scored).values
        return {"gospa_switching": float(scored.gospa_switching(switching_penalty_m).mean()),
                **{m: values[m] for m in SWITCHING_MEASURES[1:]}}
    run = run_tracker(window, tracker, params, cutoff_m=cutoff_m)
    if run.scores is not None:
        return {m: run.scores.values[m] for m in MEASURES}
    return innovation_consistency(window, run, _filters(window, tracker, params))


def _filters(dataset: Dataset, tracker: str, params: Mapping[str, Any]) -> tuple:
    """The per-sensor IMM filters of ``tracker`` built with ``params`` for ``dataset``'s sensors; ConfigError
    for a tracker without them (or one that cannot run on these sensors)."""
    filters = getattr(make_tracker(tracker, dataset.scenario.sensors, params), "filters", None)
    if filters is None:
        raise ConfigError(f"nnda tune: without truth in the dataset the objective is the innovation consistency of "
                          f"the tracks' updates, which needs a tracker that reports its contacts and has per-sensor "
                          f"IMM filters; {tracker!r} has none: tune it on a dataset with truth")
    return filters


def _objective(scores: Mapping[str, float | None]) -> float:
    value = next(iter(scores.values()))
    return float(value) if value is not None else math.inf


def _start_values(space: tuple[Dimension, ...], base) -> dict[str, float | int]:
    """The base config's values of the dimensions, those inside their ranges (the first trial)."""
    values = {d: field_value(base, d.path) for d in space}
    return {d.path: v for d, v in values.items() if d.low <= v <= d.high}


@dataclass(frozen=True)
class Search:
    """A search's trials, its best trial's number and values (by config path) and the best params (the base
    params with those values set); ``seconds`` its wall time."""

    space: tuple[Dimension, ...]
    trials: tuple[TrialRecord, ...]
    best_trial: int
    best_values: dict[str, float | int]
    best_params: dict[str, Any]
    seconds: float


def _checked_budget(trials: int, seed: int, cutoff_m: float, switching_penalty_m: float) -> None:
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise ConfigError(f"--trials {trials!r}: give a whole number of trials, 1 or more (e.g. 40)")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"--seed {seed!r}: give a whole number >= 0")
    if not (isinstance(cutoff_m, (int, float)) and cutoff_m > 0 and math.isfinite(cutoff_m)):
        raise ConfigError(f"--cutoff {cutoff_m!r}: must be a positive number of metres")
    if (isinstance(switching_penalty_m, bool) or not isinstance(switching_penalty_m, (int, float))
            or not 0 <= switching_penalty_m < math.inf):
        raise ConfigError(f"--switching-penalty {switching_penalty_m!r}: must be a number of metres >= 0 (0: the "
                          f"GOSPA objective without switching penalty)")


def search(datasets: list[Dataset], tracker: str, params: Mapping[str, Any] | None = None, trials: int = 40,
           seed: int = 0, cutoff_m: float = DEFAULT_CUTOFF_M, where: str = "tracker config",
           on_trial: Callable[[int, int], None] | None = None, keep: Sequence[str] = (),
           switching_penalty_m: float = 0.0) -> Search:
    """Search ``tracker``'s config from the base ``params`` with Optuna's seeded TPE sampler, minimising the
    mean over ``datasets`` of the objective (module docstring: GOSPA with truth, with switching penalty
    ``switching_penalty_m`` (m) when > 0, else innovation consistency); the first trial is the base config's
    values. ``keep``: dotted fields of the space (`search_space`) held at the base config's values, e.g.
    ``lifecycle.max_misses``, whose cost the objective does not see (GOSPA without switching penalty barely
    charges a track deleted and started again); ConfigError for a field not in the space, or for a switching
    penalty with a dataset without truth. ``where`` names the base config in errors, ``on_trial(done, total)``
    is called after each trial."""
    from nnda.extras import require

    _checked_budget(trials, seed, cutoff_m, switching_penalty_m)
    if switching_penalty_m > 0 and not all(has_truth(d) for d in datasets):
        raise ConfigError(f"--switching-penalty {switching_penalty_m:g}: charges the track switches of the GOSPA "
                          f"objective, which needs truth; a dataset tuned on has none (its objective is the "
                          f"innovation consistency): leave the option out")
    params = dict(params or {})
    sensors = datasets[0].scenario.sensors if datasets else None  # the class of target they declare, if any
    base = check_config(tracker, params, where, sensors)
    space = kept(search_space(base, reports=any(s.reports for d in datasets for s in d.scenario.sensors)), keep,
                 where)
    if not space:
        raise ConfigError(f"{where}: tracker {tracker!r}'s config has none of the fields nnda tune searches "
                          f"(motion noise, gate, initiation window, life-cycle or PHD thresholds)")
    optuna = require("optuna", "nnda tune")
    optuna.logging.set_verbosity(optuna.logging.WARNING)

    def objective(trial) -> float:
        values = {d.path: (trial.suggest_int(d.path, int(d.low), int(d.high), log=d.log) if d.integer else
                           trial.suggest_float(d.path, d.low, d.high, log=d.log)) for d in space}
        trial_params = with_values(params, values)
        try:
            check_config(tracker, trial_params, where, sensors)
            with warnings.catch_warnings():  # a trial's bounds hit are its score's business, not the user's
                warnings.simplefilter("ignore", BoundWarning)
                return float(np.mean([_objective(_scored(d, tracker, trial_params, cutoff_m, switching_penalty_m))
                                      for d in datasets]))
        except ConfigError as exc:  # an inconsistent combination: v_min >= v_max, m > n, ...
            raise optuna.TrialPruned(str(exc)) from None

    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=seed))
    study.enqueue_trial(_start_values(space, base))
    callbacks = [] if on_trial is None else [lambda s, t: on_trial(len(s.trials), trials)]
    start = time.perf_counter()
    study.optimize(objective, n_trials=trials, n_jobs=1, callbacks=callbacks)
    seconds = time.perf_counter() - start
    done = [t for t in study.trials if t.state.name == "COMPLETE"]
    if not done:
        raise ConfigError(f"{where}: every one of the {trials} trials was refused by the {tracker} config "
                          f"(each a ConfigError): check the base config")
    best = min(done, key=lambda t: (t.value, t.number))
    records = tuple(TrialRecord(t.number, t.state.name, t.value, dict(t.params)) for t in study.trials)
    return Search(space, records, best.number, dict(best.params), with_values(params, best.params), seconds)


def kept(space: tuple[Dimension, ...], keep: Sequence[str], where: str) -> tuple[Dimension, ...]:
    """``space`` without the dimensions of the dotted fields ``keep``; ConfigError naming ``where`` and the
    searchable fields for a field ``keep`` names that is not in the space."""
    paths = [d.path for d in space]
    unknown = [k for k in keep if k not in paths]
    if unknown:
        raise ConfigError(f"{where}: --keep {', '.join(unknown)}: not among the fields this search tunes; choose "
                          f"from {', '.join(paths)}")
    return tuple(d for d in space if d.path not in keep)


def tune(dataset: Dataset, tracker: str, params: Mapping[str, Any] | None = None, trials: int = 40,
         seed: int = 0, fraction: float = FRACTION, cutoff_m: float = DEFAULT_CUTOFF_M,
         where: str = "tracker config", on_trial: Callable[[int, int], None] | None = None,
         keep: Sequence[str] = (), switching_penalty_m: float = 0.0) -> TuneResult:
    """Search ``tracker``'s config on the first part of ``dataset`` from the base ``params`` (`search`, the
    module docstring's split; ``keep`` the fields held at the base's values; ``switching_penalty_m`` (m) the
    objective's switching penalty, 0 for none) and score the base and the best config on both parts;
    ``where`` names the base config in errors, ``on_trial(done, total)`` is called after each trial."""
    _checked_budget(trials, seed, cutoff_m, switching_penalty_m)
    params = dict(params or {})
    check_config(tracker, params, where, dataset.scenario.sensors)
    k = split_scans(dataset.n_scans, fraction)
    if has_truth(dataset):  # the default runs here (a tracker that cannot use these sensors says so now)
        make_tracker(tracker, dataset.scenario.sensors, params, where)
    else:
        _filters(dataset, tracker, params)
    parts = {"tuning": scan_window(dataset, 1, k), "held-out": scan_window(dataset, k + 1, dataset.n_scans)}
    found = search([parts["tuning"]], tracker, params, trials, seed, cutoff_m, where, on_trial, keep,
                   switching_penalty_m)
    scores = {(name, part): _scored(window, tracker, p, cutoff_m, switching_penalty_m)
              for name, p in (("default", params), ("tuned", found.best_params)) for part, window in parts.items()}
    return TuneResult(tracker, dataset.scenario.name, dataset.n_scans, k, has_truth(dataset), float(cutoff_m),
                      found.space, found.trials, found.best_trial, found.best_values, params, found.best_params,
                      scores, found.seconds, tuple(keep), float(switching_penalty_m))
