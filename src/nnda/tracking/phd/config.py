"""Configs of the PHD trackers: strict pydantic models, checked once when a tracker is configured.

Motion (``motion``): nnda's CV and CT, or the pedestrian models of Frencl
(2014): a CV with diagonal process noise (``cv-diagonal``), the modified
NCSHT [x, y, v, alpha] (``ncsht``) and its HM-map composite (``hm-map``,
with ``hm_map`` naming the map of the scene: ``corridor`` for walk-test4,
``plus`` for the walk-test3 scenes; `HM_MAPS`); the heading models take
Cartesian fixes only.

Reduction and extraction come as named parameter sets (``preset``), any of
whose four numbers an explicit field overrides:

| preset       | prune T | merge U | J_max | extraction | from                                          |
|--------------|---------|---------|-------|------------|-----------------------------------------------|
| `radar`      | 1e-5    | 4       | 100   | 0.5        | this study's radar scenes (the default)       |
| `pedestrian` | 1e-5    | 4       | 15    | 0.25       | Frencl (2014), Sec. 6.2: walking individuals  |
| `harbour`    | 1e-6    | 25      | 1000  | 0.8        | Lima (2022), Table 4.3: two radars, harbour   |

The previous version's preset and motion names are still read, mapped to
these with a FutureWarning (`RENAMED_PRESETS`, `RENAMED_MOTIONS`).

The preset also sets three PHDConfig fields (`CONFIRMATION_PRESETS`, which
explicit fields override too; the Stone Soup peer has none):
``components_per_contact`` c grows J_max to c N after a scan of N contacts
(so dense clutter's newborns do not crowd a target's components out),
``components_per_target`` c_t to c_t times the scan's expected target count
(the posterior intensity's mass before the cap: a fixed J_max of 100 holds
some 50-90 targets' components, and past that the cap drops targets; at
the radar thesis's few targets c_t = 2 stays far below J_max, so it changes
nothing there), and
``extraction_scans`` k reports a label once it has been extracted after k
sweeps in a row of one sensor (each sensor's sweeps counted apart), then
whenever it is extracted (`nnda.tracking.phd.extraction`). `radar` and
`harbour`: c = 1, c_t = 2, k = 3 (a clutter component rarely stays above the
threshold for three sweeps, a target's does); `pedestrian`: off (c and c_t
None, k = 1), as Frencl (2014). When the cap still drops components, the
tracker counts them (``n_capped_components``, ``capped_weight``) and warns
once a run (BoundWarning).

Clutter (``clutter``) is a Poisson number of false contacts per scan, of
mean lambda, spread uniformly over the radar's coverage in measurement
space, so its intensity is kappa = lambda / V: per m per rad of (range,
azimuth) for the polar linearisations (``ekf``, ``ukf``: V = (r_max -
r_min) 2 pi), per m^2 for Cartesian fixes (``linear``, or any linearisation
on a position sensor's fixes: V = pi (r_max^2 - r_min^2), or
``clutter_area_m2`` when given: a walker scene's map, width x height).
``clutter`` gives lambda as a number, or ``"scan"``: each scan's own
estimate, its contact count less the expected target detections (p_D times
the predicted target count), at least 0.001; or ``"local"``: each
contact's local density (`nnda.tracking.clutter_density.local_density`, a
square of half-side ``clutter_radius_m``), times its range for the polar
space, with lambda the contact count; or ``"unexplained"`` (the default of
``gmphd``, ``ekphd``, ``ukphd`` and ``cphd``; the harbour trackers and the
Stone Soup peer keep ``"local"``): the same squares' contacts less the contact itself and the predicted
intensity's expected detections there (p_D times the mass of the components
whose means lie in the square), at least the scan's such count over the
coverage (`nnda.tracking.clutter_density.unexplained_density`), with lambda
as ``"scan"``'s: where targets are dense, ``"local"`` counts their contacts
as clutter.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, field_validator, model_validator

from nnda.errors import ConfigError
from nnda.filters.ground_motion import DiagonalCV, GroundVehicle, HMMap, ModifiedNCSHT, corridor_hm_map, plus_hm_map
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn, MotionModel
from nnda.filters.unscented import UnscentedTransform
from nnda.tracking.protocol import TrackerConfig
from nnda.validation import check_covariance

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

#: the motions whose state is [x, y, v, alpha] (the modified NCSHT and its HM-map composite)
HEADING_MOTIONS = ("ncsht", "hm-map")
#: the HM maps of motion "hm-map" by name (`nnda.filters.ground_motion`): Test 4's corridor (scene
#: walk-test4) and Fig. 5.1's "+" (scenes walk-test3 and walk-test3-stress)
HM_MAPS: dict[str, Callable[[], HMMap]] = {"corridor": corridor_hm_map, "plus": plus_hm_map}

#: the (component, contact) pairs a scan's update forms at most by default (``max_pairs``: about 2 GB of pairs;
#: the shipped studies' densest scans, 5,000 clutter contacts, form up to 5 million)
MAX_PAIRS = 25_000_000

#: a probability of these filters: in (0, 1]
Probability = Annotated[float, Field(gt=0, le=1)]

#: reduction and extraction parameter sets by name (see the module table)
REDUCTION_PRESETS: dict[str, dict[str, float]] = {
    "radar": {"prune_threshold": 1e-5, "merge_threshold": 4.0, "max_components": 100, "extraction_threshold": 0.5},
    "pedestrian": {"prune_threshold": 1e-5, "merge_threshold": 4.0, "max_components": 15,
                   "extraction_threshold": 0.25},
    "harbour": {"prune_threshold": 1e-6, "merge_threshold": 25.0, "max_components": 1000,
                "extraction_threshold": 0.8},
}

#: the confirmation settings each preset gives a PHD filter (`PHDConfig`: not the Stone Soup peer, which has
#: neither field); c None (or 0) and k 1: off (see the module docstring)
CONFIRMATION_PRESETS: dict[str, dict[str, float | None]] = {
    "radar": {"components_per_contact": 1.0, "components_per_target": 2.0, "extraction_scans": 3},
    "pedestrian": {"components_per_contact": None, "components_per_target": None, "extraction_scans": 1},
    "harbour": {"components_per_contact": 1.0, "components_per_target": 2.0, "extraction_scans": 3},
}
#: the confirmation settings and first-sweep births turned off, as the PHD filters ran before the presets set them
#: (the studies that reproduce a reference work's numbers pin them: ``params = {**SINGLE_SCAN_EXTRACTION, ...}``)
SINGLE_SCAN_EXTRACTION: dict[str, float | bool] = {
    "components_per_contact": 0, "extraction_scans": 1, "coast_misses": 0, "first_sweep_births": False}

#: the preset and motion names of the previous version, read for one more version with a FutureWarning
RENAMED_PRESETS = {"seed-000": "pedestrian", "seed-002": "harbour"}  # deprecated spelling
RENAMED_MOTIONS = {"cv-seed-000": "cv-diagonal", "ncsht-seed-000": "ncsht"}  # deprecated spelling


def _renamed(field: str, value: Any, renamed: dict[str, str]) -> Any:
    """``value`` under its current name, warning (FutureWarning) when it is one of ``renamed``'s old names."""
    if isinstance(value, str) and value in renamed:
        warnings.warn(f"{field} {value!r} is deprecated: use {renamed[value]!r}", FutureWarning, stacklevel=2)
        return renamed[value]
    return value


def _spd(name: str, matrix: list[list[float]], n: int) -> None:
    """Raise ValueError (ConfigError) unless ``matrix`` is an n x n symmetric positive definite matrix."""
    P = np.asarray(matrix, dtype=float)
    if P.shape != (n, n):
        raise ConfigError(f"{name}: expected a {n} x {n} matrix for the state size {n}, got shape {P.shape}")
    check_covariance(name, P, error=ConfigError)


class MeasurementBirth(BaseModel):
    """Measurement-driven birth (Ristic et al. 2012, `nnda.tracking.phd.birth`): ``rate`` expected births
    per scan spread over the last scan's unexplained contacts, velocity 0 +/- ``speed_sigma_m_s``."""

    model_config = _STRICT

    kind: Literal["measurement"] = "measurement"
    rate: Annotated[float, Field(gt=0, description="expected births per scan (nu_b)")] = 0.1
    speed_sigma_m_s: Annotated[float, Field(gt=0, description="newborn velocity std per axis (m/s)")] = 100.0


class BirthComponent(BaseModel):
    """One Gaussian of a static birth intensity: weight, mean and covariance in the filter's state."""

    model_config = _STRICT

    weight: Annotated[float, Field(gt=0)]
    mean: list[float]
    covariance: list[list[float]]

    @model_validator(mode="after")
    def _covariance(self) -> BirthComponent:
        _spd("covariance", self.covariance, len(self.mean))
        return self


class StaticBirth(BaseModel):
    """Fixed birth components (Vo & Ma's gamma_k) at every scan, or at the first only (``every_scan``
    false: with the true initial states as means, the oracle birth of Frencl (2014))."""

    model_config = _STRICT

    kind: Literal["static"] = "static"
    components: Annotated[list[BirthComponent], Field(min_length=1)]
    every_scan: bool = True


class Spawn(BaseModel):
    """Spawning (Vo & Ma's beta): every component spawns one of weight ``weight`` w at its predicted mean,
    covariance F P F^T + ``covariance`` (the filter's state size)."""

    model_config = _STRICT

    weight: Annotated[float, Field(gt=0)]
    covariance: list[list[float]]


class UnscentedConfig(BaseModel):
    """Scaled unscented transform parameters (`nnda.filters.unscented.UnscentedTransform`)."""

    model_config = _STRICT

    alpha: Annotated[float, Field(gt=0)] = 1.0
    beta: float = 2.0
    kappa: float = 0.0

    def transform(self) -> UnscentedTransform:
        return UnscentedTransform(self.alpha, self.beta, self.kappa)


def _birth_kind(value: Any) -> str:
    """The birth model's ``kind`` (a mapping without one is the default, measurement-driven birth)."""
    return value.get("kind", "measurement") if isinstance(value, dict) else getattr(value, "kind", "")


class CommonConfig(TrackerConfig):
    """What every GM-PHD tracker here shares (ours and the Stone Soup peer): reduction and extraction (by
    preset), CV noise, survival and detection probabilities, clutter, the pair gate."""

    preset: Literal["radar", "pedestrian", "harbour"] = Field(
        "radar", description="named reduction/extraction set; explicit fields override it")
    prune_threshold: Annotated[float, Field(ge=0, description="drop components of weight <= T")]
    merge_threshold: Annotated[float, Field(ge=0, description="squared Mahalanobis distance U of a merge")]
    max_components: Annotated[int, Field(ge=1, description="J_max, components kept after merging")]
    extraction_threshold: Annotated[float, Field(gt=0, description="report components of weight >= this")]

    @model_validator(mode="before")
    @classmethod
    def _preset(cls, data: Any) -> Any:
        if isinstance(data, dict):
            preset = data.get("preset", cls.model_fields["preset"].default)
            preset = RENAMED_PRESETS.get(preset, preset) if isinstance(preset, str) else preset
            confirmation = {k: v for k, v in CONFIRMATION_PRESETS.get(preset, {}).items() if k in cls.model_fields}
            data = {**REDUCTION_PRESETS.get(preset, {}), **confirmation, **data}
        return data

    @field_validator("preset", mode="before")
    @classmethod
    def _old_preset(cls, value: Any) -> Any:
        return _renamed("preset", value, RENAMED_PRESETS)

    sigma_q: Annotated[float, Field(ge=0, description="acceleration noise (m/s^2) of the motion model")] = 10.0
    ps: Probability = Field(0.99, description="survival probability per scan (per shortest scan period)")
    pd: Probability = Field(0.9, description="detection probability")
    clutter: Annotated[float, Field(ge=0)] | Literal["scan", "local"] = Field(
        "local", description="false contacts per scan (lambda), or 'scan' / 'local' estimates (module docs)")
    clutter_radius_m: Annotated[float, Field(gt=0)] = 3_000.0
    gate: Annotated[float, Field(gt=0)] | None = Field(
        50.0, description="squared Mahalanobis gate of the (component, contact) pairs; None: every pair")


class PHDConfig(CommonConfig):
    """Settings of a GM-PHD tracker (see the module docstring for presets and clutter units)."""

    clutter: Annotated[float, Field(ge=0)] | Literal["scan", "local", "unexplained"] = Field(
        "unexplained", description="false contacts per scan (lambda), or 'scan' / 'local' / 'unexplained' "
        "estimates (module docs)")

    components_per_contact: Annotated[float | None, Field(
        ge=0, description="J_max grows with the scan: at most max(J_max, this x N) components are kept after "
        "a scan of N contacts, so dense clutter's newborns do not crowd out a target's; 0 or None: J_max alone "
        "(default: the preset's, `CONFIRMATION_PRESETS`)")]
    components_per_target: Annotated[float | None, Field(
        ge=0, description="J_max grows with the targets too: at least this x the scan's expected target count "
        "(the posterior intensity's mass before the cap) components are kept, so a scene of many targets keeps "
        "each target's components; 0 or None: off (default: the preset's, `CONFIRMATION_PRESETS`)")]
    max_pairs: Annotated[int | None, Field(
        ge=1, description="(component, contact) pairs a scan's update forms at most (the gate's candidates, "
        "counted before any is formed): past it, the lightest predicted components are left out of that scan's "
        "update, the heaviest kept (ties: the earlier), with a BoundWarning the first time in a run; the tracker "
        "counts them (n_dropped_components, n_dropped_pairs). Bounds memory (about 80 B a pair) and time when "
        "a scan holds far more contacts than the filter was made for; None: no bound")] = MAX_PAIRS
    extraction_scans: Annotated[int, Field(
        ge=1, description="report a label once it has been extracted (weight >= the threshold) after this many "
        "sweeps in a row of one sensor (each sensor's sweeps counted apart), then whenever it is extracted; "
        "1: every extracted component (default: the preset's, `CONFIRMATION_PRESETS`)")]
    first_sweep_births: bool = Field(
        True, description="measurement-driven birth: each sensor's first sweep with contacts puts a newborn of "
        "weight 1/n^2 on every contact, n the contacts in its clutter_radius_m square (targets present from the "
        "start; `nnda.tracking.phd.birth`); false: the first sweep's births are the later sweeps' (birth.rate)")
    coast_misses: Annotated[int, Field(ge=0)] | None = Field(
        None, description="a label already reported stays reported while its weight is at least the extraction "
        "threshold times (1 - p_D)^this (p_D the sweep's sensor's): an isolated target is shown through this many "
        "missed sweeps in a row, and one that has ended for as many sweeps after its last contact; 0: a miss hides "
        "it; None: 1 for a tracker updated by more than one sensor's sweeps, else 0 (`default_coast_misses`)")
    merge_covariance: Literal["candidate", "heaviest"] = Field(
        "candidate", description="the covariance of the merge distance: each candidate's (Vo & Ma's Table II) "
        "or the heaviest's (`nnda.filters.mixture.merge`)")
    linearisation: Literal["linear", "ekf", "ukf"] = Field(
        "ekf", description="linear: Cartesian fixes (a radar's contacts converted); ekf / ukf: polar radar")
    unscented: UnscentedConfig = UnscentedConfig()
    motion: Literal["cv", "ct", "cv-diagonal", "ncsht", "hm-map"] = Field(
        "cv", description="cv / ct: nnda's CV and CT (sigma_q, sigma_omega); cv-diagonal: a CV with diagonal "
        "process noise in position and velocity, Frencl (2014)'s (`nnda.filters.ground_motion.DiagonalCV`; "
        "sigma_q unused); ncsht: the modified NCSHT [x, y, v, alpha]; hm-map: its composite model on the HM "
        "map ``hm_map`` (`nnda.filters.ground_motion.GroundVehicle`)")
    hm_map: Literal["corridor", "plus"] | None = Field(
        None, description="the HM map of motion 'hm-map': 'corridor' (Test 4, scene walk-test4) or 'plus' "
        "(Fig. 5.1, scenes walk-test3*)")
    v0_m_s: Annotated[float, Field(ge=0, description="hm-map: preferred speed v0 (m/s)")] = 1.5
    rho: Annotated[float, Field(ge=0, le=1, description="hm-map: speed relaxation T / tau_v per step")] = 0.2
    hm_jacobian: Literal["complete", "printed"] = Field(
        "complete", description="hm-map: the transition's own Jacobian or the thesis's as printed")
    clutter_area_m2: Annotated[float, Field(gt=0)] | None = Field(
        None, description="Cartesian fixes: the area (m^2) false fixes are spread over (a walker scene: its "
        "map's); None: the sensor's coverage ring")
    sigma_omega: Annotated[float, Field(ge=0, description="turn-rate noise (rad/s) of the CT model")] = 0.044
    birth: Annotated[Annotated[MeasurementBirth, Tag("measurement")] | Annotated[StaticBirth, Tag("static")],
                     Discriminator(_birth_kind)] = MeasurementBirth()
    spawn: Spawn | None = None
    sensor_pd: Annotated[tuple[Probability, ...], Field(min_length=1)] | None = Field(
        None, description="detection probability of each sensor, in the scenario's order; None: pd for all when "
        "set, else each sensor's declared_pd, else pd's default")
    use_sensors: Annotated[tuple[str, ...], Field(min_length=1)] | None = Field(
        None, description="names of the sensors whose scans update the filter; the others' scans only "
        "predict it (a report still follows every scan); None: every sensor")

    @field_validator("motion", mode="before")
    @classmethod
    def _old_motion(cls, value: Any) -> Any:
        return _renamed("motion", value, RENAMED_MOTIONS)

    @model_validator(mode="after")
    def _state_sizes(self) -> PHDConfig:
        n = self.state_dim
        if (self.motion == "hm-map") != (self.hm_map is not None):
            raise ValueError("hm_map: give it with motion 'hm-map' (and only then): 'corridor' or 'plus'")
        if isinstance(self.birth, StaticBirth):
            layout = ("[x, y, v, alpha]" if self.motion in HEADING_MOTIONS else
                      f"[x, vx, y, vy{', omega' if n == 5 else ''}]")
            for i, c in enumerate(self.birth.components):
                if len(c.mean) != n:
                    raise ValueError(f"birth.components.{i}.mean: the {self.motion} state has {n} entries "
                                     f"({layout}), got {len(c.mean)}")
        if self.spawn is not None:
            _spd("spawn.covariance", self.spawn.covariance, n)
        if self.linearisation == "ukf" and not n + self.unscented.kappa > 0:
            raise ValueError(f"unscented.kappa: n + kappa must be > 0 for the state size {n}")
        return self

    @property
    def state_dim(self) -> int:
        """Size of the filter's state: 4 (CV, NCSHT, HM map) or 5 (CT)."""
        return 5 if self.motion == "ct" else 4

    def motion_model(self) -> MotionModel:
        if self.motion == "cv":
            return ConstantVelocity(self.sigma_q)
        if self.motion == "cv-diagonal":
            return DiagonalCV()
        if self.motion == "ncsht":
            return ModifiedNCSHT()
        if self.motion == "hm-map":
            return GroundVehicle(hm_map=HM_MAPS[self.hm_map](), v0=self.v0_m_s, rho=self.rho,
                                 jacobian=self.hm_jacobian)
        return CoordinatedTurn(sigma_q=self.sigma_q, sigma_omega=self.sigma_omega)


class GMPHDConfig(PHDConfig):
    """``gmphd``: the GM-PHD on Cartesian fixes (a radar's contacts converted with their covariance)."""

    linearisation: Literal["linear", "ekf", "ukf"] = "linear"


class EKPHDConfig(PHDConfig):
    """``ekphd``: the GM-PHD with the EKF's linearisation of the polar radar measurement."""


class UKPHDConfig(PHDConfig):
    """``ukphd``: the GM-PHD with the unscented transform of the polar radar measurement."""

    linearisation: Literal["linear", "ekf", "ukf"] = "ukf"


class CPHDConfig(PHDConfig):
    """``cphd``: the cardinalised PHD, EK linearisation by default; no spawning (the CPHD has none)."""

    max_cardinality: Annotated[int, Field(ge=1, description="N_max, the cardinality support 0..N_max (at the "
                                                          "start of a run: see cardinality_per_target)")] = 100
    cardinality_per_target: Annotated[float, Field(ge=1)] | None = Field(
        1.5, description="the support grows with the targets: once this x the expected target count (the "
        "posterior's mean) passes N_max, N_max doubles until it holds it, so a scene of more targets than "
        "max_cardinality keeps its count; None: N_max fixed, the scans whose posterior piles up at N_max "
        "counted (n_cardinality_capped) with a BoundWarning the first time in a run")
    extraction: Literal["threshold", "map"] = Field(
        "threshold", description="threshold: as the PHD; map: the MAP count's heaviest components (no "
        "coasting: coast_misses 0 or None)")

    @model_validator(mode="after")
    def _no_spawn(self) -> CPHDConfig:
        if self.spawn is not None:
            raise ValueError("spawn: the CPHD filter has no spawning model")
        if self.extraction == "map" and self.coast_misses:
            raise ValueError(f"coast_misses = {self.coast_misses}: extraction 'map' reports the MAP count's "
                             "heaviest components, which a coasting label would exceed; set coast_misses = 0 or "
                             "extraction = 'threshold'")
        return self


class CentralPHDConfig(PHDConfig):
    """The GM-PHD of the centralised harbour tracker (``fusion-central``) and of each fusion tracker's
    local filters, after Lima (2022), Table 4.3: the ``harbour`` reduction set (T 1e-6, U 25, J_max 1000,
    E 0.8), p_S 0.99, p_D 0.9, the EKF on the CT model. Lima gives no process noise: sigma_q 0.5 m/s^2
    and sigma_omega 0.02 rad/s (ships turning at up to 0.05 rad/s) are ours."""

    preset: Literal["radar", "pedestrian", "harbour"] = "harbour"
    motion: Literal["cv", "ct"] = "ct"
    clutter: Annotated[float, Field(ge=0)] | Literal["scan", "local", "unexplained"] = Field(
        "local", description="false contacts per scan (lambda), or 'scan' / 'local' / 'unexplained' "
        "estimates (module docs; the harbour trackers keep 'local', as measured)")
    first_sweep_births: bool = Field(
        False, description="each sensor's first sweep puts newborns of weight 1/n^2 on its contacts (PHDConfig); "
        "off here: the harbour model's slow, heavy components (ships: speed sigma 10 m/s, J_max 1,000, pruned "
        "at 1e-6) kept every such newborn for scans, 1-4 s a scan at 1,000 aircraft where 0.05-0.3 s without")
    sigma_q: Annotated[float, Field(ge=0, description="acceleration noise (m/s^2) of the motion model")] = 0.5
    sigma_omega: Annotated[float, Field(ge=0, description="turn-rate noise (rad/s) of the CT model")] = 0.02
    birth: Annotated[Annotated[MeasurementBirth, Tag("measurement")] | Annotated[StaticBirth, Tag("static")],
                     Discriminator(_birth_kind)] = MeasurementBirth(speed_sigma_m_s=10.0)


class FusionConfig(CentralPHDConfig):
    """A fusion centre over one local GM-PHD per sensor (`nnda.tracking.phd.fusion`): every field of
    `CentralPHDConfig` sets the local filters (``sensor_pd`` gives each its own p_D); the centre merges with
    ``merge_threshold`` and reports fused components of weight >= ``fused_extraction_threshold`` (after
    ``extraction_scans`` sweeps in a row of one sensor, as a local filter does)."""

    fused_extraction_threshold: Annotated[float, Field(gt=0, description="report fused components of weight "
                                                                         ">= this")] = 0.8


class AAFusionConfig(FusionConfig):
    """``fusion-aa``: as `FusionConfig`; a target one sensor misses keeps half its weight (two sensors), so
    the fused components are reported from weight 0.4."""

    fused_extraction_threshold: Annotated[float, Field(gt=0, description="report fused components of weight "
                                                                         ">= this")] = 0.4


class GCIFusionConfig(FusionConfig):
    """``fusion-gci``: as `FusionConfig`, with the GCI fusion weight ``omega`` of the first sensor's intensity
    (the others share 1 - omega), what becomes of a component outside the other sensors' coverage, and
    ``gate`` also bounding the pairs the fusion forms. The geometric mean of two radars' Gaussians that agree
    weighs less than either (the Bhattacharyya-type coefficient of their different covariance shapes and
    means: a median 0.42 on the harbour's ships), and after one radar's miss sqrt(1 - p_D) = 0.32 of that
    again: so the fused components are reported from weight 0.1."""

    omega: Annotated[float, Field(gt=0, lt=1, description="GCI fusion weight of the first sensor's intensity "
                                                          "(the others share the rest)")] = 0.5
    outside_coverage: Literal["drop", "keep"] = Field(
        "drop", description="drop: the plain geometric mean (zero where either intensity is); keep: a component "
        "outside the coverage of the sensors it would be fused with passes unchanged")
    fused_extraction_threshold: Annotated[float, Field(gt=0, description="report fused components of weight "
                                                                         ">= this")] = 0.1


def __getattr__(name: str) -> Any:
    if name == "HarbourConfig":
        warnings.warn("nnda.tracking.phd.config.HarbourConfig is deprecated: use CentralPHDConfig",
                      FutureWarning, stacklevel=2)
        return CentralPHDConfig
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
