"""Scene sources: where a study's (or ``nnda generate``'s) runs come from, each a seeded run plus a digest.

    sources = resolve_scenes(preset="validation")      # S1-S6, generated; or config=..., or path=...
    src = sources[0]
    src.name, src.description                           # "S1", "preset S1"
    [ds] = src.load(first=3, count=1, seed=0)           # run 3 of S1 drawn with seed 0: a Dataset
    src.digest(3)                                       # what determines that run's data (with the seed)

Every source has a ``name`` (its name in results), a ``description`` (where
it comes from, for a report), ``stored_runs`` (the runs on disk, or None
for a generated source that draws any number), ``digest(run)`` and
``load(first, count, seed)``: a list of runs (one `Dataset` each, also
one at a time from ``iterate``) or one block of runs (`FrameSet`,
`ReentryData`), the same data in any process:

* `GeneratedScenes`: a radar scenario (a preset or a config file), run r
  drawn by `nnda.data.generator.generate` from (scenario, seed, r);
* `StoredDatasets`: datasets on disk (a dataset or a collection), run r is
  the r-th member, its digest the SHA-256 of its files;
* `WalkerScenes`: a walker scene (`nnda.data.pedestrian`), run r drawn from
  (scene, seed, r);
* `FrameScenes`: image frames for track-before-detect (`nnda.data.frames`),
  run r drawn from (seed, r), so any block of runs can be drawn alone;
* `ReentryScenes`: ballistic re-entry runs (`nnda.data.reentry`), drawn
  from one generator for all runs, so a block is always runs 0..count-1.

`resolve_scenes` turns a name (preset, group or walker scene), a config
file (scenario or walker scene) or a directory of datasets into sources,
with no ``if`` on scene kinds left to the caller.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from nnda.data.changes import changed_name, changed_scenario
from nnda.data.checks import MAX_DETECTIONS
from nnda.data.dataset import (
    DETECTIONS_FILE,
    MANIFEST,
    TRUTH_FILE,
    Dataset,
    collection_members,
    is_collection,
    read_dataset,
)
from nnda.data.frames import FramesConfig, FrameSet
from nnda.data.frames import simulate as simulate_frames
from nnda.data.generator import check_scenario, generate_runs
from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.pedestrian.walkers import WalkerScene, is_walker_config, load_walker_scene, walker_runs
from nnda.data.presets import resolve
from nnda.data.reentry import ReentryConfig, ReentryData
from nnda.data.reentry import simulate as simulate_reentry
from nnda.data.scenario import Scenario, load_scenario
from nnda.errors import ConfigError, DatasetError
from nnda.files import canonical, digest, file_digest, read_config


class SceneSource(Protocol):
    """What every source offers (module docstring)."""

    name: str
    description: str

    @property
    def stored_runs(self) -> int | None: ...

    def digest(self, run: int) -> str: ...

    def load(self, first: int, count: int, seed: int): ...


def config_digest(config) -> str:
    """SHA-256 of a pydantic config's canonical JSON: equal digests, equal generated data for a seed."""
    return digest(canonical(config.model_dump(mode="json")))


class _DatasetRuns:
    """What the sources of datasets share: ``load`` is ``iterate`` collected, and nothing to check by default."""

    def load(self, first: int, count: int, seed: int | None = None) -> list[Dataset]:
        return list(self.iterate(first, count, seed))

    def check(self, max_detections: int = MAX_DETECTIONS) -> list[str]:
        return []


@dataclass(frozen=True)
class GeneratedScenes(_DatasetRuns):
    """A radar scenario whose run r is generated from (scenario, seed, r)."""

    name: str
    description: str
    scenario: Scenario
    stored_runs = None

    def digest(self, run: int) -> str:
        return config_digest(self.scenario)

    def iterate(self, first: int, count: int, seed: int | None) -> Iterator[Dataset]:
        """The runs one at a time (the noise-free plan computed once)."""
        return generate_runs(self.scenario, range(first, first + count), seed)

    def check(self, max_detections: int = MAX_DETECTIONS) -> list[str]:
        """What generation would refuse, before any draw (ConfigError); the scenario's plausibility warnings."""
        return check_scenario(self.scenario, max_detections)


@dataclass(frozen=True)
class StoredDatasets(_DatasetRuns):
    """Datasets on disk of one scenario, run r the r-th of ``paths``; ``digests`` the SHA-256 of each one's files."""

    name: str
    description: str
    scenario: Scenario
    paths: tuple[Path, ...]
    digests: tuple[str, ...]

    @property
    def stored_runs(self) -> int:
        return len(self.paths)

    def digest(self, run: int) -> str:
        return self.digests[run]

    def iterate(self, first: int, count: int, seed: int | None = None) -> Iterator[Dataset]:
        """The runs one at a time."""
        return (read_dataset(p) for p in self.paths[first:first + count])


@dataclass(frozen=True)
class WalkerScenes(_DatasetRuns):
    """A walker scene whose run r is simulated from (scene, seed, r)."""

    name: str
    description: str
    scene: WalkerScene
    stored_runs = None

    def digest(self, run: int) -> str:
        return config_digest(self.scene)

    def iterate(self, first: int, count: int, seed: int | None) -> Iterator[Dataset]:
        """The runs one at a time (a fixed-truth scene's walks simulated once)."""
        return walker_runs(self.scene, range(first, first + count), seed)


@dataclass(frozen=True)
class FrameScenes:
    """Image frames of ``config``; run r drawn from (seed, r), the background from the seed alone."""

    name: str
    description: str
    config: FramesConfig
    stored_runs = None

    def digest(self, run: int) -> str:
        return config_digest(self.config)

    def load(self, first: int, count: int, seed: int) -> FrameSet:
        return simulate_frames(self.config, count, seed, first_run=first)


@dataclass(frozen=True)
class ReentryScenes:
    """Re-entry runs of ``config``, all drawn from one generator seeded with the seed: a block starts at run 0."""

    name: str
    description: str
    config: ReentryConfig
    stored_runs = None

    def digest(self, run: int) -> str:
        return config_digest(self.config)

    def load(self, first: int, count: int, seed: int) -> ReentryData:
        if first != 0:
            raise ConfigError(f"{self.name}: re-entry runs are drawn together; a block starts at run 0, not {first}")
        return simulate_reentry(self.config, count, seed)


def dataset_digest(path: Path) -> str:
    """SHA-256 of a dataset directory's manifest, detections and truth."""
    return file_digest(path / MANIFEST, path / DETECTIONS_FILE, path / TRUTH_FILE)


def _stored(path: Path, name: str | None, shown: str) -> list[StoredDatasets]:
    """Datasets under ``path`` grouped by scenario name, each group one source."""
    if not path.is_dir():
        raise DatasetError(f"{path}: no such dataset or collection directory")
    members = collection_members(path) if is_collection(path) else [path]
    groups: dict[str, list[tuple[Path, Scenario]]] = {}
    for member in members:
        ds = read_dataset(member)
        groups.setdefault(ds.scenario.name, []).append((member, ds.scenario))
    if name is not None and len(groups) > 1:
        raise ConfigError(f"{path} holds several scenarios ({', '.join(groups)}); `name` can only rename a path "
                          f"holding one")
    return [StoredDatasets(name or scenario_name, f"datasets in {shown}", group[0][1], tuple(m for m, _ in group),
                           tuple(dataset_digest(m) for m, _ in group))
            for scenario_name, group in groups.items()]


def resolve_scenes(preset: str | None = None, config: Path | None = None, path: Path | None = None,
                   name: str | None = None, shown: str | None = None, changes: Mapping[str, Any] | None = None,
                   suffix: str | None = None) -> list[GeneratedScenes | StoredDatasets | WalkerScenes]:
    """The sources of one of: a ``preset`` name (preset, preset group or walker scene), a ``config`` file (a
    scenario, or a walker scene: one with a ``map``), a ``path`` of datasets on disk (``name`` renames its one
    scenario). ``shown`` is how descriptions name the file or directory (default: as given). ``changes`` (dotted
    path -> value, `nnda.data.changes`) change every generated radar scenario, named with ``suffix`` added
    (`changes.changed_name`); walker scenes and datasets on disk take none."""
    given = [k for k, v in (("preset", preset), ("config", config), ("path", path)) if v is not None]
    if len(given) != 1:
        raise ConfigError(f"give exactly one of preset, config or path (got {', '.join(given) or 'none'})")
    shown = shown or str(config or path)
    if preset is not None and preset in PEDESTRIAN_SCENES:
        _unchanged(changes, f"walker scene {preset}")
        return [WalkerScenes(preset, f"walker scene {preset}", PEDESTRIAN_SCENES[preset])]
    if preset is not None:
        try:
            scenarios = [(s, f"preset {s.name}") for s in resolve(preset)]
        except ConfigError as exc:
            raise ConfigError(f"{exc}, or a walker scene ({', '.join(PEDESTRIAN_SCENES)})") from None
    elif config is not None:
        if is_walker_config(read_config(config, "scenario")):
            scene = load_walker_scene(config)
            _unchanged(changes, f"walker scene {shown}")
            return [WalkerScenes(scene.name, f"walker scene {shown}", scene)]
        scenarios = [(load_scenario(config), f"config {shown}")]
    else:
        _unchanged(changes, f"the datasets at {shown}")
        return _stored(path, name, shown)
    return [_changed(s, described, changes or {}, suffix) for s, described in scenarios]


def _changed(scenario: Scenario, described: str, changes: Mapping[str, Any], suffix: str | None) -> GeneratedScenes:
    """The source of ``scenario`` (from ``described``) with ``changes``, renamed (`changes.changed_name`)."""
    if not changes:
        return GeneratedScenes(scenario.name, described, scenario)
    written = ", ".join(f"{k} = {v!r}" for k, v in changes.items())
    named = {"name": changed_name(scenario.name, changes, suffix),
             "description": f"{scenario.description}; changed: {written}"}
    changed = changed_scenario(scenario, {**changes, **named}, f"changes to {described}")
    return GeneratedScenes(changed.name, f"{described}, changed: {written}", changed)


def _unchanged(changes: Mapping[str, Any] | None, what: str) -> None:
    """ConfigError if ``changes`` are asked of ``what``, which is not a generated radar scenario."""
    if changes:
        raise ConfigError(f"changes ({', '.join(changes)}) apply to generated radar scenarios, not to {what}")


