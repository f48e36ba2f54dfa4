"""Study definition: which trackers, on which scenarios, how many runs, with which seed.

A study is validated data (pydantic), read from TOML or JSON::

    name = "thesis"
    seed = 0                  # every preset run is generated from (scenario, seed, run)
    runs = 100                # Monte Carlo runs per generated scenario
    gospa_cutoff_m = 1000.0   # GOSPA/OSPA cut-off c (p = 2, alpha = 2), also the position matching's threshold
    ownership = "auto"        # track ownership: by "contacts", by "position", or "auto" (nnda.study.metrics)

    ablation = "models/ablation"  # optional: an `nnda train --ablation` directory, shown in the report

    [models]                  # trained association networks (`nnda train` output or model.json)
    lm = "models/lm"

    [trackers.nn-lm]          # a label of your choice -> a registered tracker kind
    kind = "nn"
    model = "lm"              # passed to the tracker as params["model"] = the model file's path
                              # (the tracker computes the feature set the model was trained on)
    [trackers.gnn]
    kind = "gnn"
    params = { gate = 9.21 }  # the tracker's own validated config

    [filters.imm-cv]          # optional: a single-target filter (nnda.filters.single_target), run on the
    kind = "imm"              # study's single-target scenarios with the target's own contacts
    params = { motion = "cv" }

    [[scenarios]]
    preset = "validation"     # a preset or a preset group (S1-S6 here)
    [[scenarios]]
    config = "my.toml"        # a scenario config file, generated like a preset
    [[scenarios]]
    path = "data/recorded"    # a dataset or a collection: its members are the runs
    name = "recorded"

Relative paths are resolved against the study file's directory. Defaults
where the specification is silent: seed 0, 10 runs, GOSPA cut-off 1000 m
(the order of the initiation window and gates for this radar), track
ownership "auto" (by contacts when a tracker's outputs report them, by
position otherwise), 95% t-intervals over runs.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, model_validator

from nnda.errors import ConfigError, validated
from nnda.files import read_config
from nnda.models.features import KINEMATIC
from nnda.models.innovation import IMM_INNOVATION
from nnda.study.metrics import DEFAULT_CUTOFF_M, Ownership
from nnda.tracking.neural import life5

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
#: labels become file and directory names, so they are kept to a safe alphabet (and start with no dot)
Label = Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_\-][A-Za-z0-9_.\-]*$")]

#: the tracker parameter that receives a model file's path
MODEL_PARAM = "model"


class TrackerSpec(BaseModel):
    """One tracker of the study: a registered kind, its parameters and optionally a model."""

    model_config = _STRICT

    kind: Annotated[str, Field(min_length=1, description="registered tracker name (nnda.tracking.registry)")]
    model: Label | None = Field(default=None, description="label of an entry of [models]")
    params: dict[str, Any] = Field(default_factory=dict, description="the tracker's config")

    @model_validator(mode="after")
    def _model_given_once(self) -> TrackerSpec:
        if self.model is not None and MODEL_PARAM in self.params:
            raise ValueError(f"give the model as `model = \"<label>\"`, not as params.{MODEL_PARAM}")
        return self


class FilterSpec(BaseModel):
    """One single-target filter of the study: a registered kind and its parameters."""

    model_config = _STRICT

    kind: Annotated[str, Field(min_length=1, description="registered filter name (nnda.filters.single_target)")]
    params: dict[str, Any] = Field(default_factory=dict, description="the filter's config")


class ScenarioSpec(BaseModel):
    """Where one or more scenarios come from: a preset (or group), a config file, or datasets on disk."""

    model_config = _STRICT

    preset: str | None = Field(default=None, description="preset or preset group name")
    config: Path | None = Field(default=None, description="scenario config file (.toml or .json)")
    path: Path | None = Field(default=None, description="dataset or collection directory")
    name: Label | None = Field(default=None, description="name in the report (path scenarios)")

    @model_validator(mode="after")
    def _one_source(self) -> ScenarioSpec:
        given = [k for k in ("preset", "config", "path") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of preset, config or path (got {', '.join(given) or 'none'})")
        if self.name is not None and self.path is None:
            raise ValueError("name is for path scenarios; presets and configs keep their own names")
        return self


class Study(BaseModel):
    """A comparison study (see the module docstring for the file format)."""

    model_config = _STRICT

    name: Label = "study"
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    runs: Annotated[int, Field(ge=1, description="Monte Carlo runs of each generated scenario")] = 10
    gospa_cutoff_m: Annotated[float, Field(
        gt=0, description="GOSPA/OSPA cut-off c (m), also the threshold of the position matching")] = DEFAULT_CUTOFF_M
    ownership: Ownership = Field(default="auto", description="track ownership: auto, contacts or position")
    confidence: Annotated[float, Field(gt=0, lt=1, description="level of the t-intervals")] = 0.95
    models: dict[Label, Path] = Field(default_factory=dict)
    ablation: Path | None = Field(default=None, description="`nnda train --ablation` output for the report")
    trackers: dict[Label, TrackerSpec] = Field(default_factory=dict)
    filters: dict[Label, FilterSpec] = Field(default_factory=dict, description="single-target filters: jobs "
                                             "on the study's single-target scenarios")
    scenarios: Annotated[list[ScenarioSpec], Field(min_length=1)]
    #: the directory relative paths were resolved against (the study file's), set by `resolved`
    _base: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _models_declared(self) -> Study:
        if not self.trackers and not self.filters:
            raise ValueError("name at least one tracker ([trackers.<label>]) or filter ([filters.<label>])")
        both = sorted(set(self.trackers) & set(self.filters))
        if both:
            raise ValueError(f"label(s) {', '.join(both)} name both a tracker and a filter; labels must differ")
        for label, spec in self.trackers.items():
            if spec.model is not None and spec.model not in self.models:
                raise ValueError(f"tracker {label!r} uses model {spec.model!r}, which [models] does not declare "
                                 f"(declared: {', '.join(self.models) or 'none'})")
        return self

    def resolved(self, base: Path) -> Study:
        """A copy with every relative path made absolute against ``base``."""
        def fix(p: Path | None) -> Path | None:
            return None if p is None else (p if p.is_absolute() else base / p).resolve()

        copy = self.model_copy(update={
            "models": {k: fix(v) for k, v in self.models.items()}, "ablation": fix(self.ablation),
            "scenarios": [s.model_copy(update={"config": fix(s.config), "path": fix(s.path)})
                          for s in self.scenarios],
        })
        copy._base = base.resolve()
        return copy

    def __eq__(self, other: object) -> bool:
        """Equal fields: where the study file was read from (``_base``) does not make two studies differ."""
        return isinstance(other, Study) and self.model_dump() == other.model_dump()

    def __hash__(self) -> int:
        return hash(self.model_dump_json())

    def relative(self, path: Path) -> str:
        """``path`` as results record it: relative to the study file's directory (so the same study gives
        the same results from any directory), or as it is when there is no such directory."""
        if self._base is None:
            return str(path)
        return os.path.relpath(path, self._base)

    def inputs(self) -> list[Path]:
        """Every file or directory the study reads: model files, scenario configs, datasets, the ablation."""
        paths = [*self.models.values(), *(s.config or s.path for s in self.scenarios if s.preset is None)]
        return paths + ([self.ablation] if self.ablation is not None else [])


def study_from_dict(data: dict, source: str = "<study>", base: Path | None = None) -> Study:
    """Validate a mapping into a Study (relative paths against ``base``, default the cwd)."""
    study = validated(Study, data, source, "study")
    return study.resolved(base if base is not None else Path.cwd())


def load_study(path: str | Path) -> Study:
    """Read a study from a ``.toml`` or ``.json`` file; paths inside are relative to its directory."""
    path = Path(path)
    return study_from_dict(read_config(path, "study"), str(path), path.parent.resolve())


def default_study(gd_model: str | Path, lm_model: str | Path, ext_model: str | Path, runs: int = 100,
                  seed: int = 0, ablation: str | Path | None = None) -> Study:
    """The specification's comparison (seed-001 §10.2) and issue 9's: IMM/TOMHT against the neural
    tracker with the seed's features (gradient-descent and Levenberg-Marquardt models: ``nn-gd``,
    ``nn-seed``) and with the IMM-extended features (``nn-ext``; ``nn-life`` with issue 20's settings
    for coasting and young tracks, `nnda.tracking.neural.life5`), plus the GNN and JPDA baselines and the
    association-free EK-PHD and CPHD filters (``ekphd``, ``cphd``, issue 14), on S1-S6.

    Model paths are kept as given (relative ones are resolved when the study is written and read).
    """
    seed_set, ext_set = {"feature_set": KINEMATIC.name}, {"feature_set": IMM_INNOVATION.name}
    return Study(
        name="thesis-comparison",
        description="IMM + track-oriented MHT against neural association (seed features with GD and LM "
                    "models, IMM-extended features with LM, alone and with issue 20's life cycle for coasting "
                    "tracks), with GNN and JPDA baselines and the EK-PHD and CPHD filters, on S1-S6",
        seed=seed, runs=runs,
        models={"gd": Path(gd_model), "lm": Path(lm_model), "ext": Path(ext_model)},
        ablation=None if ablation is None else Path(ablation),
        trackers={"mht": TrackerSpec(kind="mht"),
                  "nn-gd": TrackerSpec(kind="nn", model="gd", params=seed_set),
                  "nn-seed": TrackerSpec(kind="nn", model="lm", params=seed_set),
                  "nn-ext": TrackerSpec(kind="nn", model="ext", params=ext_set),
                  "nn-life": TrackerSpec(kind="nn", model="ext", params={**ext_set, **life5()}),
                  "gnn": TrackerSpec(kind="gnn"), "jpda": TrackerSpec(kind="jpda"),
                  "ekphd": TrackerSpec(kind="ekphd"), "cphd": TrackerSpec(kind="cphd")},
        scenarios=[ScenarioSpec(preset="validation")],
    )


# ----------------------------------------------------------------------------- writing

def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ConfigError(f"study: cannot write the non-finite number {value} to TOML")
        return repr(value)
    if isinstance(value, (str, Path)):
        return json.dumps(str(value))  # a JSON string is a valid TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + " }"
    raise ConfigError(f"study: cannot write {type(value).__name__} values to TOML")


def _toml_key(key: str) -> str:
    return key if key.replace("-", "").replace("_", "").isalnum() else json.dumps(key)


def study_to_toml(study: Study, relative_to: Path | None = None) -> str:
    """The study as a TOML document that `load_study` reads back to an equal study.

    Paths under ``relative_to`` (the directory the file will live in) are written relative to it.
    """
    def path(p: Path) -> str:
        if relative_to is not None and p.is_absolute():
            try:
                return str(p.relative_to(relative_to.resolve()))
            except ValueError:
                return str(p)
        return str(p)

    lines = [f"{k} = {_toml_value(getattr(study, k))}"
             for k in ("name", "description", "seed", "runs", "gospa_cutoff_m", "ownership", "confidence")]
    if study.ablation is not None:
        lines.append(f"ablation = {_toml_value(path(study.ablation))}")
    if study.models:
        lines += ["", "[models]"] + [f"{_toml_key(k)} = {_toml_value(path(v))}" for k, v in study.models.items()]
    for label, spec in study.trackers.items():
        lines += ["", f"[trackers.{_toml_key(label)}]", f"kind = {_toml_value(spec.kind)}"]
        if spec.model is not None:
            lines.append(f"model = {_toml_value(spec.model)}")
        if spec.params:
            lines.append(f"params = {_toml_value(spec.params)}")
    for label, spec in study.filters.items():
        lines += ["", f"[filters.{_toml_key(label)}]", f"kind = {_toml_value(spec.kind)}"]
        if spec.params:
            lines.append(f"params = {_toml_value(spec.params)}")
    for s in study.scenarios:
        lines += ["", "[[scenarios]]"]
        for key in ("preset", "config", "path", "name"):
            value = getattr(s, key)
            if value is not None:
                lines.append(f"{key} = {_toml_value(path(value) if isinstance(value, Path) else value)}")
    return "\n".join(lines) + "\n"
