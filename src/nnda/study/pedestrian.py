"""The pedestrian study (Frencl 2014, Tests 1-4): PHD filters and motion models on simulated walkers.

Test 1 draws the heading profiles (their variance against the objectivity
parameter, closed form beside 10,000 draws, polar histograms and pdf
curves). Each later test runs its filters on the same Monte Carlo runs of
its scenes (`nnda.data.pedestrian.scenes`; every filter sees the same
contacts). The study engine runs it as the ``pedestrian`` job kind
(`nnda.study.kinds.pedestrian`): one job per (scene, filter, block of
runs), `run_block`, each run scored in the job (`nnda.study.pedestrian_scores`),
and `study_results` builds the results document from the records.

* Test 2 (Tables 6.1, 6.2, Fig. 6.8): GM-PHD + CV, EK-PHD and UK-PHD +
  modified NCSHT; accuracy on ``walk-test2`` (one walker, the same
  trajectory in every run), target count and runtime on ``walk-stress``.
* Test 3 (Tables 6.3, 6.4): the EK-PHD with CV, modified NCSHT and the
  HM-map composite on the "+" map (``walk-test3``, ``walk-test3-stress``).
* Test 4 (Table 6.5, Fig. 6.19): the EK-PHD with modified NCSHT without
  and with the corridor's HM map on ``walk-test4`` (a new trajectory per run).

Every filter takes the thesis's parameter block (the reduction set of
Frencl (2014), p_D = p_S = 0.99, the ground radar's R, spawn weight 0.05 with
covariance Q(1 s)), clutter lambda = 2e-3 per m^2 times the map's area,
spread over the map (``clutter_area_m2``), and measurement-driven birth
(rate 0.1 per scan, newborn speed 0 +/- 1.5 m/s per axis); ``birth =
"oracle"`` is the thesis's: weight-0.1 components at the walkers' true
first states, B = diag(2^2, 2^2, 1.5^2, 1.36^2) in [x y vx vy] or [x y v
alpha], at the first scan only (reported as its own study).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from threadpoolctl import threadpool_limits

from nnda.data.dataset import Dataset
from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.pedestrian.walkers import WalkerScene
from nnda.data.sources import resolve_scenes
from nnda.errors import validated
from nnda.filters.ground_motion import DiagonalCV
from nnda.filters.imm import IMM
from nnda.filters.measurement import measurement_model
from nnda.study.pedestrian_scores import Trace, density, score_accuracy, score_run, score_stress
from nnda.tracking.lifecycle import THESIS_LIFECYCLE
from nnda.tracking.output import CONFIRMED
from nnda.tracking.protocol import Tracker
from nnda.tracking.registry import TRACKERS, make_tracker

TESTS = ("test1", "test2", "test3", "test4")
#: the thesis's birth covariance diag in its [x y vx vy] / [x y v alpha] order
BIRTH_STD = (2.0, 2.0, 1.5, 1.36)
#: the thesis's birth and spawn weights
BIRTH_WEIGHT, SPAWN_WEIGHT = 0.1, 0.05
#: measurement-driven birth: expected births per scan and the newborn's speed std per axis (m/s; ours)
BIRTH_RATE, BIRTH_SPEED_SIGMA = 0.1, 1.5
#: the thesis's unscented central weight W0 = 2/3 is kappa = 2 n for n = 4 (`nnda.filters.unscented`)
UKF_KAPPA = 8.0
#: the motions whose state is [x, y, v, alpha] (the oracle birth's layout)
HEADING = ("ncsht", "hm-map")
#: the PHD trackers (the others are contact trackers: `contact_tracker`)
PHD_KINDS = ("gmphd", "ekphd", "ukphd", "cphd")
#: the contact trackers' initiation window tops at this speed (m/s; person set A's fastest: 2 + 2 x 1)
WALKER_MAX_SPEED_M_S = 4.5

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@dataclass(frozen=True)
class FilterSpec:
    """One filter of a test: report label, tracker kind, motion and its extra tracker parameters."""

    label: str
    kind: str
    motion: str
    extra: tuple[tuple[str, object], ...] = ()


_GM_CV = FilterSpec("GM-PHD + CV", "gmphd", "cv-diagonal")
_EK_NC = FilterSpec("EK-PHD + NCSHT", "ekphd", "ncsht")
_UK_NC = FilterSpec("UK-PHD + NCSHT", "ukphd", "ncsht", (("unscented", {"kappa": UKF_KAPPA}),))


@dataclass(frozen=True)
class TestSpec:
    """A test: its accuracy scene, its stress scene (None: none), its filters, which config field sets its
    accuracy runs."""

    name: str
    title: str
    accuracy: str
    stress: str | None
    filters: tuple[FilterSpec, ...]
    runs_field: str


TEST_SPECS = {t.name: t for t in (
    TestSpec("test2", "Test 2: GM-PHD + CV vs EK-PHD and UK-PHD + modified NCSHT", "walk-test2", "walk-stress",
             (_GM_CV, _EK_NC, _UK_NC), "runs"),
    TestSpec("test3", "Test 3: the EK-PHD with CV, modified NCSHT and the HM-map model on the '+' map",
             "walk-test3", "walk-test3-stress",
             (FilterSpec("EK-PHD + CV", "ekphd", "cv-diagonal"), _EK_NC,
              FilterSpec("EK-PHD + NCSHT + HM map", "ekphd", "hm-map", (("hm_map", "plus"),))), "runs"),
    TestSpec("test4", "Test 4: the EK-PHD without and with the HM map in the corridor", "walk-test4", None,
             (FilterSpec("EK-PHD, no HM map", "ekphd", "ncsht"),
              FilterSpec("EK-PHD, HM map", "ekphd", "hm-map", (("hm_map", "corridor"),))), "test4_runs"),
)}
#: beyond the thesis: nnda's contact trackers and the CPHD on the stress scene's walkers, beside two of its PHDs
BEYOND = (_GM_CV, _EK_NC, FilterSpec("CPHD + CV", "cphd", "cv-diagonal"), FilterSpec("GNN", "gnn", "cv-diagonal"),
          FilterSpec("JPDA", "jpda", "cv-diagonal"), FilterSpec("MHT", "mht", "cv-diagonal"))
BEYOND_SCENE = "walk-stress"


class PedestrianStudyConfig(BaseModel):
    """The study: which ``tests`` and whether the comparison ``beyond`` the thesis, accuracy ``runs`` of Tests
    2-3 and ``test4_runs`` of Test 4,
    ``stress_runs`` of the stress scenes (target count, runtime), ``seed``, ``birth``, the cut-off
    ``cutoff_m``, ``bootstrap`` resamples, the intervals' ``confidence``, ``block_runs``, the runs one job
    filters (the results do not depend on it), and ``max_memory_gib``, the most memory (GiB) a job or the
    aggregation may need by the study's estimate (None: the default, `nnda.study.kinds.base.MAX_MEMORY_GIB`; a
    bigger study is refused when it is planned)."""

    model_config = _STRICT

    tests: Annotated[tuple[Literal["test1", "test2", "test3", "test4"], ...], Field(min_length=1)] = TESTS
    beyond: bool = True
    runs: Annotated[int, Field(ge=2)] = 300
    test4_runs: Annotated[int, Field(ge=2)] = 600
    stress_runs: Annotated[int, Field(ge=2)] = 25
    seed: Annotated[int, Field(ge=0)] = 0
    birth: Literal["measurement", "oracle"] = "measurement"
    cutoff_m: Annotated[float, Field(gt=0)] = 2.0
    bootstrap: Annotated[int, Field(ge=100)] = 1000
    confidence: Annotated[float, Field(gt=0, lt=1)] = 0.95
    block_runs: Annotated[int, Field(ge=1)] = 25
    max_memory_gib: Annotated[float, Field(gt=0)] | None = None


# ----------------------------------------------------------------------------- one run


def filter_params(f: FilterSpec, scene: WalkerScene, birth: str, dataset: Dataset | None = None) -> dict:
    """The tracker parameters of filter ``f`` on ``scene`` (module docstring); ``birth`` "oracle" needs the
    run's ``dataset`` (its walkers' first states)."""
    area = scene.map.width_m * scene.map.height_m
    params: dict = {"preset": "pedestrian", "motion": f.motion, "pd": 0.99, "ps": 0.99,
                    "clutter": scene.radar.clutter_per_m2 * area, "clutter_area_m2": area, **dict(f.extra)}
    if f.kind != "cphd":  # the CPHD has no spawning
        motion = TRACKERS[f.kind].config_type(**params).motion_model()
        params["spawn"] = {"weight": SPAWN_WEIGHT,
                           "covariance": motion.noise(np.asarray(scene.scan_period_s)).tolist()}
    if birth == "measurement":
        params["birth"] = {"kind": "measurement", "rate": BIRTH_RATE, "speed_sigma_m_s": BIRTH_SPEED_SIGMA}
        return params
    t = dataset.truth
    first = t.scan == t.scan.min()
    x, y, vx, vy = t.x[first], t.y[first], t.vx[first], t.vy[first]
    if f.motion in HEADING:
        means = np.column_stack([x, y, np.hypot(vx, vy), np.arctan2(vy, vx)])
    else:
        means = np.column_stack([x, vx, y, vy])
    sx, sy, sv, sa = BIRTH_STD
    cov = np.diag([sx**2, sy**2, sv**2, sa**2]) if f.motion in HEADING else np.diag([sx**2, sv**2, sy**2, sa**2])
    params["birth"] = {"kind": "static", "every_scan": False, "components": [
        {"weight": BIRTH_WEIGHT, "mean": m.tolist(), "covariance": cov.tolist()} for m in means]}
    return params


def contact_tracker(f: FilterSpec, scene: WalkerScene, sensors: tuple) -> Tracker:
    """A contact tracker for walkers (the comparison beyond the thesis): the thesis's CV as a one-model IMM,
    the ground radar's p_D and clutter density, an initiation window of 0-``WALKER_MAX_SPEED_M_S``, and the
    radar thesis's life cycle (M/N, no track-quality deletion: `THESIS_LIFECYCLE`), as measured before the
    contact trackers' default changed."""
    params: dict = {"lifecycle": {**THESIS_LIFECYCLE, "v_min": 0.0, "v_max": WALKER_MAX_SPEED_M_S}, **dict(f.extra)}
    if f.kind in ("jpda", "mht"):
        params |= {"pd": scene.radar.pd, "clutter_density": scene.radar.clutter_per_m2}
    cls = TRACKERS[f.kind]
    config = validated(cls.config_type, params, f.label, f"{f.kind} config")
    imm = IMM(models=(DiagonalCV(),), measurement=measurement_model(sensors[0]), tpm=((1.0,),), mu0=(1.0,))
    return cls(sensors, config, track_filter=imm)


def track(f: FilterSpec, scene: WalkerScene, dataset: Dataset, birth: str) -> Trace:
    """Run filter ``f`` through one run's scans (one BLAS thread), timing each step; a contact tracker's
    confirmed tracks are its estimates (its weight: their number)."""
    with threadpool_limits(1):
        sensors = dataset.scenario.sensors
        phd = f.kind in PHD_KINDS
        tracker = (make_tracker(f.kind, sensors, filter_params(f, scene, birth, dataset)) if phd else
                   contact_tracker(f, scene, sensors))
        scans, xy, extracted, weight, seconds = [], [], [], [], 0.0
        for scan in dataset.scans():
            start = time.perf_counter()
            out = tracker.step(scan)
            seconds += time.perf_counter() - start
            state = out.state[out.status == CONFIRMED]
            scans.append(np.full(len(state), scan.index))
            xy.append(state[:, [0, 2]])
            extracted.append(len(state))
            weight.append(tracker.cardinality.mean if phd else len(state))
    t = dataset.truth
    return Trace(t.scan.astype(np.int64), np.column_stack([t.x, t.y]), np.concatenate(scans).astype(np.int64),
                 np.concatenate(xy).reshape(-1, 2), np.array(extracted), np.array(weight), seconds)


def run_block(scene_name: str, f: FilterSpec, first: int, count: int, seed: int, birth: str, cutoff_m: float,
              keep_estimates: bool) -> list[dict]:
    """Filter ``f`` on runs ``first``..``first + count - 1`` of walker scene ``scene_name`` (its source,
    `nnda.data.sources.WalkerScenes`: run r drawn from (seed, r), so a block is the same alone as among all runs):
    each run's record (`score_run`)."""
    (source,) = resolve_scenes(preset=scene_name)
    scene = source.scene
    return [score_run(track(f, scene, ds, birth), scene.n_scans, cutoff_m, keep_estimates)
            for ds in source.iterate(first, count, seed)]


@dataclass(frozen=True)
class RunGroup:
    """Filters on the same runs of one scene: ``role`` "accuracy", "stress" or "beyond" of test ``test``
    (None for the comparison beyond the thesis)."""

    test: str | None
    role: str
    scene: str
    filters: tuple[FilterSpec, ...]
    runs: int

    @property
    def keeps_estimates(self) -> bool:
        """Test 4's accuracy runs keep their estimates for the density map."""
        return self.test == "test4" and self.role == "accuracy"


def groups(cfg: PedestrianStudyConfig) -> list[RunGroup]:
    """Every group of runs the study's tests (and the comparison beyond them) filter, in report order."""
    out = []
    for name in cfg.tests:
        spec = TEST_SPECS.get(name)
        if spec is None:
            continue
        out.append(RunGroup(name, "accuracy", spec.accuracy, spec.filters, getattr(cfg, spec.runs_field)))
        if spec.stress is not None:
            out.append(RunGroup(name, "stress", spec.stress, spec.filters, cfg.stress_runs))
    if cfg.beyond:
        out.append(RunGroup(None, "beyond", BEYOND_SCENE, BEYOND, cfg.stress_runs))
    return out


def study_results(cfg: PedestrianStudyConfig, runs: dict[tuple[str, str], list[dict]], test1: dict | None) -> dict:
    """The results document (runtimes included) from every filter's run records by (scene, filter label), in run
    order, and Test 1's results."""
    def group_runs(g: RunGroup) -> dict[str, list[dict]]:
        return {f.label: runs[g.scene, f.label][:g.runs] for f in g.filters}

    def seconds(g: RunGroup) -> float:
        return sum(r["timing"]["seconds"] for rs in group_runs(g).values() for r in rs)

    tests, beyond = {}, None
    for g in groups(cfg):
        scene = PEDESTRIAN_SCENES[g.scene]
        if g.role == "beyond":
            beyond = {"scene": g.scene, **score_stress(group_runs(g), scene.n_scans, cfg.confidence)}
            continue
        spec = TEST_SPECS[g.test]
        test = tests.setdefault(g.test, {
            "name": spec.name, "title": spec.title, "accuracy_scene": spec.accuracy,
            "filters": {f.label: {"kind": f.kind, "motion": f.motion, **dict(f.extra)} for f in spec.filters},
            "runtime_s": 0.0})
        test["runtime_s"] += seconds(g)
        if g.role == "accuracy":
            test["accuracy"] = score_accuracy(group_runs(g), scene.n_scans, cfg.seed, cfg.bootstrap, cfg.confidence,
                                              cfg.tests.index(g.test))
            if g.keeps_estimates:
                test["density"] = {label: density(rs, scene.map.width_m, scene.map.height_m)
                                   for label, rs in group_runs(g).items()}
        else:
            test["stress_scene"] = g.scene
            test["stress"] = score_stress(group_runs(g), scene.n_scans, cfg.confidence)
    out = {"config": cfg.model_dump(mode="json", exclude={"max_memory_gib"}), "tests": list(tests.values())}
    if test1 is not None:
        out["test1"] = test1
    if beyond is not None:
        out["beyond"] = beyond
    runtime = sum(r["timing"]["seconds"] for rs in runs.values() for r in rs)
    return out | {"runtime_s": runtime}
