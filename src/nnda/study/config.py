"""The study file: a few common fields and a table (or top-level fields) per job kind it uses.

A study is validated data (pydantic), read from TOML or JSON::

    name = "thesis"
    description = "..."
    seed = 0                  # every random draw of every job comes from (seed, what the job is)
    confidence = 0.95         # level of every interval of the summary and the report

    ...                       # then what to run: each kind's fields (`nnda.study.kinds`), e.g.
    [trackers.gnn]            # the track kind (with runs, [models], [[scenarios]], ...)
    kind = "gnn"
    [[scenarios]]
    preset = "validation"

    [reentry]                 # or the re-entry particle filters, the track-before-detect filters, ...
    runs = 100

The fields a kind adds are in its module's docstring. A study names at
least one kind's work. Relative paths anywhere in the file are resolved
against the file's directory. Defaults where the reference works are
silent: seed 0, 95% intervals.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Annotated, Any

import tomli_w
from pydantic import BaseModel, Field, PrivateAttr, create_model, model_validator

from nnda.errors import ConfigError, validated
from nnda.files import read_config
from nnda.models.features import KINEMATIC
from nnda.models.innovation import IMM_INNOVATION
from nnda.study.kinds import KINDS
from nnda.study.kinds.base import STRICT, Label
from nnda.study.kinds.track import ScenarioSpec, TrackerSpec
from nnda.tracking.lifecycle import THESIS_LIFECYCLE
from nnda.tracking.neural import life5
from nnda.tracking.phd.config import SINGLE_SCAN_EXTRACTION


def _map_paths(value: Any, fn) -> Any:
    """``value`` with ``fn`` applied to every `Path` inside it (through models, mappings and sequences)."""
    if isinstance(value, Path):
        return fn(value)
    if isinstance(value, BaseModel):
        return value.model_copy(update={k: _map_paths(getattr(value, k), fn) for k in type(value).model_fields})
    if isinstance(value, dict):
        return {k: _map_paths(v, fn) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_map_paths(v, fn) for v in value)
    return value


class StudyBase(BaseModel):
    """The fields every study has; `Study` adds each registered kind's (module docstring)."""

    model_config = STRICT

    name: Label = "study"
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    confidence: Annotated[float, Field(gt=0, lt=1, description="level of the intervals")] = 0.95
    #: the directory relative paths were resolved against (the study file's), set by `resolved`
    _base: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _kinds_checked(self) -> StudyBase:
        if not any(kind.given(self) for kind in KINDS.values()):
            raise ValueError(f"name what to run: at least one of {', '.join(k.work for k in KINDS.values())}")
        for kind in KINDS.values():
            kind.check(self)
        return self

    def resolved(self, base: Path) -> StudyBase:
        """A copy with every relative path made absolute against ``base``."""
        copy = _map_paths(self, lambda p: (p if p.is_absolute() else base / p).resolve())
        copy._base = base.resolve()
        return copy

    def __eq__(self, other: object) -> bool:
        """Equal fields: where the study file was read from (``_base``) does not make two studies differ."""
        return isinstance(other, StudyBase) and self.model_dump() == other.model_dump()

    def __hash__(self) -> int:
        return hash(self.model_dump_json())

    def relative(self, path: Path) -> str:
        """``path`` as results record it: relative to the study file's directory (so the same study gives
        the same results from any directory), or as it is when there is no such directory."""
        if self._base is None:
            return str(path)
        return os.path.relpath(path, self._base)

    def inputs(self) -> list[Path]:
        """Every file or directory the study reads (model files, scenario configs, datasets, ...)."""
        found: list[Path] = []
        _map_paths(self, found.append)
        return found


def study_model() -> type[StudyBase]:
    """The study-file model of the registered kinds: the common fields and every kind's (a kind registered later,
    as in a test, is part of the next model asked for)."""
    return _model(tuple(KINDS.values()))


@functools.lru_cache(maxsize=8)
def _model(kinds: tuple) -> type[StudyBase]:
    return create_model("Study", __base__=StudyBase, __doc__="A study (see the module docstring for the file format).",
                        **{name: spec for kind in kinds for name, spec in kind.fields.items()})


#: the study-file model of nnda's own kinds
Study = study_model()


def study_from_dict(data: dict, source: str = "<study>", base: Path | None = None) -> Study:
    """Validate a mapping into a Study (relative paths against ``base``, default the cwd)."""
    study = validated(study_model(), data, source, "study")
    for path in study.inputs():
        if "\x00" in str(path):
            raise ConfigError(f"{source}: path {str(path)!r} holds a NUL character; give a file or directory path")
    try:
        return study.resolved(base if base is not None else Path.cwd())
    except (OSError, RuntimeError, ValueError) as exc:  # a symlink loop, a name too long, ...
        raise ConfigError(f"{source}: a path of the study cannot be resolved ({exc}); give a file or directory "
                          f"path") from None


def load_study(path: str | Path) -> Study:
    """Read a study from a ``.toml`` or ``.json`` file; paths inside are relative to its directory."""
    path = Path(path)
    return study_from_dict(read_config(path, "study"), str(path), path.parent.resolve())


def default_study(gd_model: str | Path, lm_model: str | Path, ext_model: str | Path, runs: int = 100,
                  seed: int = 0, ablation: str | Path | None = None) -> Study:
    """The radar thesis's comparison (Vargas Avila 2015, S1-S6): IMM/TOMHT against the neural tracker with the
    thesis's features (gradient-descent and Levenberg-Marquardt models: ``nn-gd``, ``nn-seed``) and with the
    IMM-extended features (``nn-ext``; ``nn-life`` with the life cycle for coasting and young tracks,
    `nnda.tracking.neural.life5`), plus the GNN and JPDA baselines and the association-free EK-PHD and CPHD
    filters (``ekphd``, ``cphd``).

    Model paths are kept as given (relative ones are resolved when the study is written and read).
    """
    thesis = {"lifecycle": THESIS_LIFECYCLE}  # the thesis's M/N rule, pinned: its comparison keeps its numbers
    # (and MHT's initiation from the contacts the global hypothesis leaves free, as then)
    phd = dict(SINGLE_SCAN_EXTRACTION)  # and the PHD filters' extraction as measured then
    seed_set = {"feature_set": KINEMATIC.name, **thesis}
    ext_set = {"feature_set": IMM_INNOVATION.name, **thesis}
    return Study(
        name="thesis-comparison",
        description="IMM + track-oriented MHT against neural association (the thesis's three features with GD and LM "
                    "models, IMM-extended features with LM, alone and with the life cycle for coasting tracks), "
                    "with GNN and JPDA baselines and the EK-PHD and CPHD filters, on S1-S6",
        seed=seed, runs=runs,
        models={"gd": Path(gd_model), "lm": Path(lm_model), "ext": Path(ext_model)},
        ablation=None if ablation is None else Path(ablation),
        trackers={"mht": TrackerSpec(kind="mht", params={**thesis, "initiation_contacts": "unchosen"}),
                  "nn-gd": TrackerSpec(kind="nn", model="gd", params=seed_set),
                  "nn-seed": TrackerSpec(kind="nn", model="lm", params=seed_set),
                  "nn-ext": TrackerSpec(kind="nn", model="ext", params=ext_set),
                  "nn-life": TrackerSpec(kind="nn", model="ext", params={**ext_set, **life5()}),
                  "gnn": TrackerSpec(kind="gnn", params=thesis), "jpda": TrackerSpec(kind="jpda", params=thesis),
                  "ekphd": TrackerSpec(kind="ekphd", params=phd),
                  "cphd": TrackerSpec(kind="cphd", params={**phd, "clutter": "local"})},  # its clutter as then
        scenarios=[ScenarioSpec(preset="validation")],
    )


def _pruned(value: Any) -> Any:
    """``value`` without None entries and empty tables (TOML has no null)."""
    if isinstance(value, dict):
        kept = {k: _pruned(v) for k, v in value.items() if v is not None}
        return {k: v for k, v in kept.items() if v != {}}
    if isinstance(value, list):
        return [_pruned(v) for v in value]
    return value


def study_to_toml(study: Study, relative_to: Path | None = None) -> str:
    """The study as a TOML document that `load_study` reads back to an equal study (defaults left out: a kind's
    table then gives no seed of its own).

    Paths under ``relative_to`` (the directory the file will live in) are written relative to it.
    """
    def path(p: Path) -> Path:
        if relative_to is not None and p.is_absolute():
            try:
                return p.relative_to(relative_to.resolve())
            except ValueError:
                return p
        return p

    data = _pruned(_map_paths(study, path).model_dump(mode="json", exclude_defaults=True))
    try:
        return tomli_w.dumps(data)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"study: cannot be written as TOML ({exc})") from None
