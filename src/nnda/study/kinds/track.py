"""The ``track`` kind: every tracker of the study on every run of every scenario, measured and scored.

Its study-file fields stand at the top of the file (the original study
format, so every earlier study file reads as it did)::

    runs = 100                # Monte Carlo runs per generated scenario
    gospa_cutoff_m = 1000.0   # GOSPA/OSPA cut-off c (p = 2, alpha = 2), also the position matching's threshold
    ownership = "auto"        # track ownership: "contacts", "position" or "auto" (nnda.study.metrics)
    ablation = "models/ablation"  # optional: an `nnda train --ablation` directory, shown in the report

    [models]                  # trained association networks (`nnda train` output or model.json)
    lm = "models/lm"

    [trackers.nn-lm]          # a label of your choice -> a registered tracker kind
    kind = "nn"
    model = "lm"              # passed to the tracker as params["model"] = the model file's path
    [trackers.gnn]
    kind = "gnn"
    params = { gate = 9.21 }  # the tracker's own validated config
    lag = 3                   # optional: also score its fixed-lag output 3 scans behind (nnda.tracking.lag)

    [tuning]                  # optional: every tracker also fitted to the scenes, as <label>-tuned
    trials = 20               # (nnda.study.tuned_trackers)

    [[scenarios]]
    preset = "validation"     # a preset, a preset group or a walker scene (S1-S6 here)
    [[scenarios]]
    config = "my.toml"        # a scenario (or walker scene) config file, generated like a preset
    [[scenarios]]
    path = "data/recorded"    # a dataset or a collection: its members are the runs
    name = "recorded"

A job is one tracker over one run (`nnda.study.track_job`). Its *key* is a
SHA-256 over what determines its record: the scenario's config or the
dataset's bytes, the tracker kind and parameters with the model file's
digest in place of its path, run, seed, GOSPA cut-off, track ownership when
it is not the default "auto", the tracker's lag when it is not 0, the nnda version. The aggregates are
`nnda.study.track_results`'s tables and summaries, the models' classifier
figures (`nnda.study.classifier`) and the ablation named by the study.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, Field, model_validator

from nnda.data.dataset import Dataset
from nnda.data.scenario import Scenario, Sensor
from nnda.data.sources import GeneratedScenes, StoredDatasets, WalkerScenes, resolve_scenes
from nnda.errors import ConfigError, DatasetError, ModelError
from nnda.files import file_digest, path_component
from nnda.models.scorer import MODEL_FILE, load_model
from nnda.study.classifier import read_ablation
from nnda.study.kinds.base import STRICT, Job, JobKind, Label, MemoryPart, check_memory, job_key
from nnda.study.metrics import DEFAULT_CUTOFF_M, Ownership
from nnda.study.track_job import run_job
from nnda.study.track_results import aggregate
from nnda.study.tuned_trackers import TuningSpec, tuned_params
from nnda.tracking.lag import MAX_LAG
from nnda.tracking.registry import PEERS, TRACKERS, make_tracker

#: the tracker parameter that receives a model file's path
MODEL_PARAM = "model"


class TrackerSpec(BaseModel):
    """One tracker of the study: a registered kind, its parameters and optionally a model."""

    model_config = STRICT

    kind: Annotated[str, Field(min_length=1, description="registered tracker name (nnda.tracking.registry)")]
    model: Label | None = Field(default=None, description="label of an entry of [models]")
    params: dict[str, Any] = Field(default_factory=dict, description="the tracker's config")
    lag: Annotated[int, Field(ge=0, le=MAX_LAG, strict=True, description=(
        "scans of fixed lag: besides the online output, score the output of scan k - lag revised with the "
        "scans up to k (nnda.tracking.lag); 0: online only"), exclude_if=lambda lag: lag == 0)] = 0

    @model_validator(mode="after")
    def _model_given_once(self) -> TrackerSpec:
        if self.model is not None and MODEL_PARAM in self.params:
            raise ValueError(f"give the model as `model = \"<label>\"`, not as params.{MODEL_PARAM}")
        return self


class ScenarioSpec(BaseModel):
    """Where one or more scenarios come from: a preset (or group, or walker scene), a config file, or datasets
    on disk (`nnda.data.sources.resolve_scenes`); a generated radar scenario's fields may be ``changes``d."""

    model_config = STRICT

    preset: str | None = Field(default=None, description="preset, preset group or walker scene name")
    config: Path | None = Field(default=None, description="scenario or walker scene config file (.toml or .json)")
    path: Path | None = Field(default=None, description="dataset or collection directory")
    name: Label | None = Field(default=None, description="name in the report (path scenarios)")
    changes: dict[str, Any] = Field(default_factory=dict, description="fields of the generated radar scenarios "
                                    "to change, by dotted path (clutter.count, sensor.pd, sensors.1.clutter.count, "
                                    "duration_s, targets.0.speed_m_s): for a preset group, of every member")
    suffix: str | None = Field(default=None, description="added to the name of each changed scenario (default: "
                               "the changes written out, S1-clutter.count_1000)")

    @model_validator(mode="after")
    def _one_source(self) -> ScenarioSpec:
        given = [k for k in ("preset", "config", "path") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of preset, config or path (got {', '.join(given) or 'none'})")
        if self.name is not None and self.path is None:
            raise ValueError("name is for path scenarios; presets and configs keep their own names (a changed "
                             "one takes a suffix)")
        if self.suffix is not None and not self.changes:
            raise ValueError("suffix names a changed scenario: give changes too")
        return self


FIELDS = {
    "runs": (Annotated[int, Field(ge=1, description="Monte Carlo runs of each generated scenario")], 10),
    "gospa_cutoff_m": (Annotated[float, Field(
        gt=0, description="GOSPA/OSPA cut-off c (m), also the threshold of the position matching")], DEFAULT_CUTOFF_M),
    "ownership": (Ownership, Field(default="auto", description="track ownership: auto, contacts or position")),
    "models": (dict[Label, Path], Field(default_factory=dict)),
    "ablation": (Path | None, Field(default=None, description="`nnda train --ablation` output for the report")),
    "trackers": (dict[Label, TrackerSpec], Field(default_factory=dict)),
    "scenarios": (list[ScenarioSpec], Field(default_factory=list, description="the scenes of the tracker and "
                                            "filter jobs")),
    "tuning": (TuningSpec | None, Field(default=None, description="fit every tracker to the scenes with the same "
                                       "budget and compare the tuned twins too (nnda.study.tuned_trackers)")),
    "max_memory_gib": (Annotated[float, Field(gt=0)] | None, Field(
        default=None, description="the most memory (GiB) the aggregation of the tracker and filter jobs may need "
        "by the study's estimate (None: the default, nnda.study.kinds.base.MAX_MEMORY_GIB); a bigger study is "
        "refused when it is planned")),
}


def check(study) -> None:
    """Model labels resolve; a tracker or filter study names scenarios."""
    for label, spec in study.trackers.items():
        if spec.model is not None and spec.model not in study.models:
            raise ValueError(f"tracker {label!r} uses model {spec.model!r}, which [models] does not declare "
                             f"(declared: {', '.join(study.models) or 'none'})")
    if (study.trackers or study.filters) and not study.scenarios:
        raise ValueError("trackers and filters run on scenarios: add at least one [[scenarios]] entry")


# ----------------------------------------------------------------------------- the plan


@dataclass(frozen=True)
class ScenarioPlan:
    """One scenario of the study: its source (`nnda.data.sources`) and how many runs it gives."""

    name: str
    source: GeneratedScenes | StoredDatasets | WalkerScenes
    runs: int

    @property
    def scenario(self) -> Scenario:
        return self.source.scenario

    @property
    def description(self) -> str:
        return self.source.description


@dataclass(frozen=True)
class ModelPlan:
    """A model file of the study: label, path of the JSON file, content digest, its metadata."""

    label: str
    path: Path
    sha256: str
    metadata: dict


@dataclass(frozen=True)
class TrackerPlan:
    """A tracker of the study; ``params`` already hold the model path when it has one."""

    label: str
    kind: str
    params: dict
    model: str | None = None
    lag: int = 0


@dataclass(frozen=True)
class TrackJob:
    """Everything a worker needs to run one tracker over one run; ``kind`` is the tracker's registered name."""

    scenario: str
    tracker: str
    run: int
    kind: str
    params: dict
    seed: int
    cutoff_m: float
    source: GeneratedScenes | StoredDatasets | WalkerScenes
    ownership: str = "auto"
    lag: int = 0

    @property
    def keeps_tracks(self) -> bool:
        """Run 0 keeps its tracks and the truth for the report's trajectory plot."""
        return self.run == 0

    def dataset(self) -> Dataset:
        """The run's data: the same for every tracker (a worker runs a run's trackers one after another, so the
        last runs it loaded are kept, `_RECENT`)."""
        key = (self.source.description, self.source.digest(self.run), self.run, self.seed)
        if key not in _RECENT:
            if len(_RECENT) >= 2:
                del _RECENT[next(iter(_RECENT))]
            _RECENT[key] = self.source.load(self.run, 1, self.seed)[0]
        return _RECENT[key]


#: the datasets this process loaded last, by (source, digest, run, seed): the plan lists a run's trackers together
_RECENT: dict[tuple, Dataset] = {}


def relpath(scenario: str, label: str, run: int) -> str:
    """Where a tracker or filter job's record lives inside the study directory."""
    return f"jobs/{scenario}/{label}/run-{run:04d}.json"


def _clutter_per_scan(scenario: Scenario) -> int | list[int]:
    """The clutter points of a sweep (0 for law "none"): a number for one sensor, one per sensor for several."""
    counts = [sn.clutter.count if sn.clutter.law != "none" else 0 for sn in scenario.sensors]
    return counts[0] if len(counts) == 1 else counts


@dataclass(frozen=True)
class TrackPlan:
    """The checked tracker part of a study: scenarios, models, trackers and jobs (scenario, run, tracker order)."""

    study: Any
    scenarios: tuple[ScenarioPlan, ...]
    models: tuple[ModelPlan, ...]
    trackers: tuple[TrackerPlan, ...]
    jobs: tuple[Job, ...]
    ablation: dict | None = None

    def manifest(self) -> dict:
        return {
            "scenarios": [{"name": s.name, "source": s.description, "runs": s.runs, "n_scans": s.scenario.n_scans,
                           "targets": [t.name for t in s.scenario.targets],
                           "clutter_per_scan": _clutter_per_scan(s.scenario),
                           "scenario": s.scenario.model_dump(mode="json")} for s in self.scenarios],
            "models": [{"label": m.label, "path": str(m.path), "sha256": m.sha256, "metadata": m.metadata}
                       for m in self.models],
            "trackers": [{"label": t.label, "kind": t.kind, "model": t.model,
                          "params": {k: v for k, v in t.params.items() if k != MODEL_PARAM},
                          **({"lag": t.lag} if t.lag else {})}
                         for t in self.trackers],
        }


def _models(study, where: str) -> tuple[ModelPlan, ...]:
    plans = []
    for label, path in study.models.items():
        try:
            scorer = load_model(path)
        except ModelError as exc:
            raise ModelError(f"{where}: model {label!r}: {exc}") from None
        file = path / MODEL_FILE if path.is_dir() else path
        plans.append(ModelPlan(label, file, file_digest(file), scorer.metadata))
    return tuple(plans)


@functools.lru_cache(maxsize=4)
def scenario_plans(study, where: str) -> tuple[ScenarioPlan, ...]:
    """The study's scenarios, each checked (what generation would refuse, before any job) and named once; shared
    by the tracker and filter jobs (cached: datasets on disk are read once)."""
    plans: list[ScenarioPlan] = []
    for i, spec in enumerate(study.scenarios):
        here = f"{where}: scenarios[{i}]"
        shown = study.relative(spec.config or spec.path) if spec.preset is None else None
        try:
            sources = resolve_scenes(spec.preset, spec.config, spec.path, spec.name, shown, spec.changes,
                                     spec.suffix)
        except (ConfigError, DatasetError) as exc:
            raise type(exc)(f"{here}: {exc}") from None
        plans += [ScenarioPlan(s.name, s, s.stored_runs or study.runs) for s in sources]
    for p in plans:
        try:
            p.source.check()
        except ConfigError as exc:
            raise ConfigError(f"{where}: scenario {p.name!r}: {exc}") from None
    names = [path_component(p.name, f"{where}: scenario name") for p in plans]  # they name job directories
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"{where}: scenario name(s) {', '.join(twice)} appear more than once; "
                          f"give path scenarios a distinct `name`")
    return tuple(plans)


def sensor_setups(scenarios) -> list[tuple[Sensor, ...]]:
    """The distinct sets of sensors of ``scenarios`` (a tracker or filter is built once on each)."""
    return list({str([s.model_dump_json() for s in sc.scenario.sensors]): sc.scenario.sensors
                 for sc in scenarios}.values())


def _trackers(study, models: tuple[ModelPlan, ...], sensors: list[tuple[Sensor, ...]], where: str
              ) -> tuple[TrackerPlan, ...]:
    model_path = {m.label: m.path for m in models}
    plans = []
    for label, spec in study.trackers.items():
        params = dict(spec.params)
        if spec.model is not None:
            params[MODEL_PARAM] = str(model_path[spec.model])
        for setup in sensors:  # builds each tracker once per distinct set of sensors: validates kind and params
            make_tracker(spec.kind, setup, params, where=f"{where}: tracker {label!r}")
        plans.append(TrackerPlan(label, spec.kind, params, spec.model, spec.lag))
    return tuple(plans)


def _tuned(study, trackers: tuple[TrackerPlan, ...], scenarios, where: str) -> tuple[TrackerPlan, ...]:
    """The trackers, each followed by its tuned twin when the study has a ``tuning`` table."""
    if study.tuning is None:
        return trackers
    twins = tuned_params(study, trackers, scenarios, where)
    return tuple(p for t, (label, params) in zip(trackers, twins, strict=True)
                 for p in (t, TrackerPlan(label, t.kind, params, t.model, t.lag)))


#: bytes per scan of one run's record of a tracker or filter in the aggregation (its per-scan measures and
#: tracks as Python objects: measured about 500 B on the presets, more with dense clutter's false tracks)
RECORD_BYTES = 1024


def memory_parts(study, scenarios: tuple[ScenarioPlan, ...]) -> list[MemoryPart]:
    """The memory estimate of the tracker and filter jobs: a job holds one run (its size checked with the
    scenario: `nnda.data.checks.check_size`); the aggregation every job's record, `RECORD_BYTES` per scan."""
    scans = [sc.runs * sc.scenario.n_scans for sc in scenarios]
    single = [n for n, sc in zip(scans, scenarios, strict=True) if len(sc.scenario.targets) == 1]
    # a tracker with a lag records its lagged measures too
    scored = sum(2 if spec.lag else 1 for spec in study.trackers.values()) * (1 if study.tuning is None else 2)
    records = sum(scans) * scored + sum(single) * len(study.filters)
    most = max((sc.scenario.n_scans for sc in scenarios), default=0)
    return [MemoryPart("the aggregation", f"runs = {study.runs:,} of each generated scenario, {len(scenarios)} "
                       f"scenario(s) of up to {most:,} scans, {len(study.trackers)} tracker(s), "
                       f"{len(study.filters)} filter(s)", "runs, the scenarios or the trackers",
                       records * RECORD_BYTES)]


def plan(study, where: str) -> TrackPlan:
    """Check every input of the tracker jobs and list them; ``where`` names the study in error messages."""
    for label, spec in study.trackers.items():  # the cheapest check first
        if spec.kind not in TRACKERS:
            raise ConfigError(f"{where}: tracker {label!r}: unknown tracker {spec.kind!r}; "
                              f"registered trackers: {', '.join([*TRACKERS, *PEERS])}")
    models = _models(study, where)
    scenarios = scenario_plans(study, where)
    check_memory(where, None, memory_parts(study, scenarios), study.max_memory_gib)
    trackers = _tuned(study, _trackers(study, models, sensor_setups(scenarios), where), scenarios, where)
    model_digest = {m.label: m.sha256 for m in models}
    ids = {t.label: {"kind": t.kind, "model_sha256": model_digest.get(t.model),
                     "params": {k: v for k, v in t.params.items() if k != MODEL_PARAM},
                     **({"lag": t.lag} if t.lag else {})} for t in trackers}  # no lag: the keys of before
    # leaving the default ownership out keeps the keys of studies planned before the option existed
    ownership = {} if study.ownership == "auto" else {"ownership": study.ownership}
    jobs = []
    for sc in scenarios:
        for run in range(sc.runs):
            for t in trackers:
                key = job_key({"scenario": sc.name, "data": sc.source.digest(run), "tracker": t.label,
                               **ids[t.label], "run": run, "seed": study.seed, "cutoff_m": study.gospa_cutoff_m,
                               **ownership})
                spec = TrackJob(scenario=sc.name, tracker=t.label, run=run, kind=t.kind, params=t.params,
                                seed=study.seed, cutoff_m=study.gospa_cutoff_m, source=sc.source,
                                ownership=study.ownership, lag=t.lag)
                jobs.append(Job("track", key, relpath(sc.name, t.label, run), f"{t.label} on {sc.name} run {run}",
                                spec))
    ablation = read_ablation(study.ablation) if study.ablation is not None else None
    return TrackPlan(study, scenarios, models, trackers, tuple(jobs), ablation)


#: the tracker jobs plan the study's scenarios, so a study of filters alone has a track part with no trackers
KIND = JobKind(name="track", fields=FIELDS, work="[trackers.<label>]",
               given=lambda study: bool(study.trackers or study.filters), plan=plan, run=run_job,
               aggregate=aggregate, check=check)
