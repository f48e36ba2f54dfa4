"""A study resolved into independent jobs, every input checked first.

A job is one of two kinds (``JobSpec.task``): "track", a tracker over one
run of a scenario (every scenario, every tracker), or "filter", a
single-target filter over one run of a single-target scenario with the
target's own contacts (`nnda.filters.single_target`). Both share the keys,
the resume rule, local processes and Dask (`nnda.study.runner`).

`plan_study` reads every model file and dataset the study names and builds
every tracker once with its parameters, so a wrong tracker name, a missing
model file or a directory that is not an nnda dataset fails with a clear
message before any job runs.

Each job carries a *key*: a SHA-256 over what determines its result (the
scenario's config or the dataset's bytes, the tracker kind and parameters
with the model file's digest in place of its path, run, seed, GOSPA
cut-off, track ownership when it is not the default "auto", the task when
it is not "track", nnda version).
A saved job result is reused on resume only under the same key; the
study's *fingerprint* hashes all keys. (Leaving the default ownership out
keeps the keys, and the fingerprints, of studies planned before the option
existed.)
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nnda.data.dataset import (
    DETECTIONS_FILE,
    MANIFEST,
    TRUTH_FILE,
    collection_members,
    is_collection,
    read_dataset,
)
from nnda.data.generator import check_scenario
from nnda.data.presets import resolve
from nnda.data.scenario import Scenario, Sensor, load_scenario
from nnda.errors import ConfigError, DatasetError, ModelError
from nnda.files import digest, file_digest, path_component
from nnda.filters.single_target import make_filter
from nnda.models.scorer import MODEL_FILE, load_model
from nnda.study.config import MODEL_PARAM, Study
from nnda.tracking.registry import PEERS, TRACKERS, make_tracker
from nnda.version import __version__

STUDY_FORMAT = "nnda.study"
STUDY_FORMAT_VERSION = 1


@dataclass(frozen=True)
class ScenarioPlan:
    """One scenario of the study and where its runs come from.

    Generated scenarios (presets, config files) have no ``datasets``: run r is
    `nnda.data.generator.generate(scenario, seed, r)`. Scenarios read from disk list one
    dataset directory per run, with the content digest of each.
    """

    name: str
    source: str
    scenario: Scenario
    runs: int
    datasets: tuple[Path, ...] = ()
    dataset_digests: tuple[str, ...] = ()

    @property
    def generated(self) -> bool:
        return not self.datasets


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


@dataclass(frozen=True)
class FilterPlan:
    """A single-target filter of the study and the single-target scenarios it runs on."""

    label: str
    kind: str
    params: dict
    scenarios: tuple[str, ...]


@dataclass(frozen=True)
class JobSpec:
    """Everything a worker needs to run one job; picklable, no open files.

    ``tracker`` is the label of the tracker or, for a "filter" ``task``, of the filter; ``kind`` its
    registered name.
    """

    scenario: str
    tracker: str
    run: int
    kind: str
    params: dict
    seed: int
    cutoff_m: float
    key: str
    ownership: str = "auto"
    generate: Scenario | None = None
    dataset: Path | None = None
    task: str = "track"

    @property
    def keeps_tracks(self) -> bool:
        """Run 0 keeps its tracks and the truth for the report's trajectory plot."""
        return self.run == 0

    @property
    def relpath(self) -> str:
        """Where the job's result lives inside the study directory."""
        return f"jobs/{self.scenario}/{self.tracker}/run-{self.run:04d}.json"


def _clutter_per_scan(scenario: Scenario) -> int | list[int]:
    """The clutter points of a sweep (0 for law "none"): a number for one sensor, one per sensor for several."""
    counts = [sn.clutter.count if sn.clutter.law != "none" else 0 for sn in scenario.sensors]
    return counts[0] if len(counts) == 1 else counts


@dataclass(frozen=True)
class StudyPlan:
    """The checked study: scenarios, models, trackers and jobs (scenario, run, tracker order)."""

    study: Study
    scenarios: tuple[ScenarioPlan, ...]
    models: tuple[ModelPlan, ...]
    trackers: tuple[TrackerPlan, ...]
    jobs: tuple[JobSpec, ...]
    filters: tuple[FilterPlan, ...] = ()

    @property
    def fingerprint(self) -> str:
        return digest(*(j.key.encode() for j in self.jobs))

    def manifest(self) -> dict:
        """The ``study.json`` content: what was run, on what, with which inputs."""
        return {
            "format": STUDY_FORMAT,
            "format_version": STUDY_FORMAT_VERSION,
            "nnda_version": __version__,
            "fingerprint": self.fingerprint,
            "study": self.study.model_dump(mode="json"),
            "scenarios": [{"name": s.name, "source": s.source, "runs": s.runs, "n_scans": s.scenario.n_scans,
                           "targets": [t.name for t in s.scenario.targets],
                           "clutter_per_scan": _clutter_per_scan(s.scenario),
                           "scenario": s.scenario.model_dump(mode="json")} for s in self.scenarios],
            "models": [{"label": m.label, "path": str(m.path), "sha256": m.sha256, "metadata": m.metadata}
                       for m in self.models],
            "trackers": [{"label": t.label, "kind": t.kind, "model": t.model,
                          "params": {k: v for k, v in t.params.items() if k != MODEL_PARAM}}
                         for t in self.trackers],
            "jobs": len(self.jobs),
        }


def _canonical(data: Any) -> bytes:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), default=str).encode()


def _models(study: Study, where: str) -> tuple[ModelPlan, ...]:
    plans = []
    for label, path in study.models.items():
        try:
            scorer = load_model(path)
        except ModelError as exc:
            raise ModelError(f"{where}: model {label!r}: {exc}") from None
        file = path / MODEL_FILE if path.is_dir() else path
        plans.append(ModelPlan(label, file, file_digest(file), scorer.metadata))
    return tuple(plans)


def _dataset_digest(path: Path) -> str:
    return file_digest(path / MANIFEST, path / DETECTIONS_FILE, path / TRUTH_FILE)


def _from_disk(path: Path, name: str | None, where: str, shown: str) -> list[ScenarioPlan]:
    """Datasets under ``path`` grouped by scenario name, each group one scenario of the study."""
    try:
        if not path.is_dir():
            raise DatasetError(f"{path}: no such dataset or collection directory")
        members = collection_members(path) if is_collection(path) else [path]
        groups: dict[str, list[tuple[Path, Scenario]]] = {}
        for member in members:
            ds = read_dataset(member)
            groups.setdefault(ds.scenario.name, []).append((member, ds.scenario))
    except DatasetError as exc:
        raise DatasetError(f"{where}: {exc}") from None
    if name is not None and len(groups) > 1:
        raise ConfigError(f"{where}: {path} holds several scenarios ({', '.join(groups)}); "
                          f"`name` can only rename a path holding one")
    plans = []
    for scenario_name, group in groups.items():
        dirs = tuple(m for m, _ in group)
        plans.append(ScenarioPlan(name or scenario_name, f"datasets in {shown}", group[0][1], len(dirs), dirs,
                                  tuple(_dataset_digest(d) for d in dirs)))
    return plans


def _scenarios(study: Study, where: str) -> tuple[ScenarioPlan, ...]:
    plans: list[ScenarioPlan] = []
    for i, spec in enumerate(study.scenarios):
        here = f"{where}: scenarios[{i}]"
        if spec.preset is not None:
            try:
                found = resolve(spec.preset)
            except ConfigError as exc:
                raise ConfigError(f"{here}: {exc}") from None
            plans += [ScenarioPlan(s.name, f"preset {s.name}", s, study.runs) for s in found]
        elif spec.config is not None:
            try:
                s = load_scenario(spec.config)
            except ConfigError as exc:
                raise ConfigError(f"{here}: {exc}") from None
            plans.append(ScenarioPlan(s.name, f"config {study.relative(spec.config)}", s, study.runs))
        else:
            plans += _from_disk(spec.path, spec.name, here, study.relative(spec.path))
    for p in plans:  # what generation would refuse (size, clutter outside the coverage), before any job
        if p.generated:
            try:
                check_scenario(p.scenario)
            except ConfigError as exc:
                raise ConfigError(f"{where}: scenario {p.name!r}: {exc}") from None
    names = [path_component(p.name, f"{where}: scenario name") for p in plans]  # they name job directories
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"{where}: scenario name(s) {', '.join(twice)} appear more than once; "
                          f"give path scenarios a distinct `name`")
    return tuple(plans)


def _trackers(study: Study, models: tuple[ModelPlan, ...], sensors: list[tuple[Sensor, ...]], where: str
              ) -> tuple[TrackerPlan, ...]:
    model_path = {m.label: m.path for m in models}
    plans = []
    for label, spec in study.trackers.items():
        params = dict(spec.params)
        if spec.model is not None:
            params[MODEL_PARAM] = str(model_path[spec.model])
        for setup in sensors:  # builds each tracker once per distinct set of sensors: validates kind and params
            make_tracker(spec.kind, setup, params, where=f"{where}: tracker {label!r}")
        plans.append(TrackerPlan(label, spec.kind, params, spec.model))
    return tuple(plans)


def plan_study(study: Study, where: str = "study") -> StudyPlan:
    """Check every input of ``study`` and list its jobs; ``where`` names the study in error messages."""
    for label, spec in study.trackers.items():  # the cheapest check first
        if spec.kind not in TRACKERS:
            raise ConfigError(f"{where}: tracker {label!r}: unknown tracker {spec.kind!r}; "
                              f"registered trackers: {', '.join([*TRACKERS, *PEERS])}")
    models = _models(study, where)
    scenarios = _scenarios(study, where)
    sensors = list({str([s.model_dump_json() for s in sc.scenario.sensors]): sc.scenario.sensors
                    for sc in scenarios}.values())
    trackers = _trackers(study, models, sensors, where)
    model_digest = {m.label: m.sha256 for m in models}
    tracker_ids = {t.label: {"kind": t.kind, "model_sha256": model_digest.get(t.model),
                             "params": {k: v for k, v in t.params.items() if k != MODEL_PARAM}}
                   for t in trackers}
    ownership = {} if study.ownership == "auto" else {"ownership": study.ownership}
    jobs = []
    for sc in scenarios:
        source = digest(_canonical(sc.scenario.model_dump(mode="json"))) if sc.generated else None
        for run in range(sc.runs):
            data_id = source if sc.generated else sc.dataset_digests[run]
            for t in trackers:
                key = digest(_canonical({
                    "nnda": __version__, "scenario": sc.name, "data": data_id, "tracker": t.label,
                    **tracker_ids[t.label], "run": run, "seed": study.seed, "cutoff_m": study.gospa_cutoff_m,
                    **ownership,
                }))
                jobs.append(JobSpec(
                    scenario=sc.name, tracker=t.label, run=run, kind=t.kind, params=t.params, seed=study.seed,
                    cutoff_m=study.gospa_cutoff_m, key=key, ownership=study.ownership,
                    generate=sc.scenario if sc.generated else None,
                    dataset=None if sc.generated else sc.datasets[run],
                ))
    filters = _filters(study, scenarios, where)
    for sc in scenarios:
        source = digest(_canonical(sc.scenario.model_dump(mode="json"))) if sc.generated else None
        for run in range(sc.runs):
            data_id = source if sc.generated else sc.dataset_digests[run]
            for f in filters:
                if sc.name not in f.scenarios:
                    continue
                key = digest(_canonical({
                    "nnda": __version__, "task": "filter", "scenario": sc.name, "data": data_id,
                    "filter": f.label, "kind": f.kind, "params": f.params, "run": run, "seed": study.seed,
                }))
                jobs.append(JobSpec(
                    scenario=sc.name, tracker=f.label, run=run, kind=f.kind, params=f.params, seed=study.seed,
                    cutoff_m=study.gospa_cutoff_m, key=key, generate=sc.scenario if sc.generated else None,
                    dataset=None if sc.generated else sc.datasets[run], task="filter",
                ))
    return StudyPlan(study, scenarios, models, trackers, tuple(jobs), filters)


def _filters(study: Study, scenarios: tuple[ScenarioPlan, ...], where: str) -> tuple[FilterPlan, ...]:
    """The study's filters, each built once per distinct set of sensors (validates kind and params), on
    the single-target scenarios."""
    if not study.filters:
        return ()
    single = tuple(sc for sc in scenarios if len(sc.scenario.targets) == 1)
    if not single:
        counts = ", ".join(f"{sc.name} ({len(sc.scenario.targets)})" for sc in scenarios)
        raise ConfigError(f"{where}: filters run on single-target scenarios, and this study has none "
                          f"(targets per scenario: {counts})")
    setups = list({str([s.model_dump_json() for s in sc.scenario.sensors]): sc.scenario.sensors
                   for sc in single}.values())
    plans = []
    for label, spec in study.filters.items():
        for setup in setups:
            make_filter(spec.kind, setup, spec.params, where=f"{where}: filter {label!r}")
        plans.append(FilterPlan(label, spec.kind, dict(spec.params), tuple(sc.name for sc in single)))
    return tuple(plans)
