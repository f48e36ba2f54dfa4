"""The walker simulator of Frencl (2014), Sec. 4.2, and its scenes, ending in an nnda `Dataset`.

Walkers are born at generators (the first at time 0, later ones at
spontaneous births and by spawning beside a walker), walk from waypoint to
waypoint toward a final sink, stop and go, and leave at a sink. One step of
period T (s) for every living walker at once (arrays over walkers, a Python
loop over steps only)::

    ds = generate_walkers(PEDESTRIAN_SCENES["walk-test2"], seed=0, run=0)   # nnda Dataset
    ds.truth          # one row per walker per scan (x, y, vx, vy; m, m/s)
    ds.detections     # a ground radar's Cartesian fixes and clutter (kind "position")

Per step, for each walker (eqs. 4.1-4.7 of the thesis):

1. reached the capture radius of its waypoint: the next one is the linked
   name whose direction from the walker is closest (largest dot product) to
   the direction of its final sink;
2. direction blend: u = theta h + (1 - theta) d, theta ~ U(0, 1), h the unit
   heading, d the unit vector to the waypoint (every step: `BLEND`);
3. stop and go: the walker moves with probability c f_t, c its continuity and
   f_t the facility of its cell (`nnda.data.pedestrian.terrain.FACILITY`);
   a stopped walker keeps its place with velocity 0;
4. speed s = mean + std N(0, 1), clipped to [`MIN_SPEED_M_S`, mean + 3 std];
   heading alpha = angle(u) + delta, delta from the scene's heading profile;
5. position p + s T (cos alpha, sin alpha), velocity s (cos alpha, sin alpha),
   unless the step meets an obstacle or leaves the map (tested at points
   every half cell along it): then the walker stays (velocity 0) and its
   heading is the blend's (`COLLISION`);
6. a walker standing in a sink cell after its step is reported at that scan
   and removed.

Headings here are mathematical (rad, counter-clockwise from east); the
scenario records each walker's first heading as a pilot's (degrees clockwise
from north).

Everything the thesis leaves open is a named default here: `FACILITY`
(blue 0.9, yellow 0.6), `BLEND`, `COLLISION`, `MIN_SPEED_M_S`, the speed law
(Gaussian), births after time 0 (Poisson, ``birth_rate_per_s`` over all
generators, a generator chosen uniformly), spawns (``spawned`` walkers at
steps uniform in 1..``spawn_until_s``/T, each at a living walker's position
and heading, or at a generator when none lives), a walker's final sink
(uniform among the sinks its links reach), a newborn's place (uniform over
its generator's cells).

Random streams: truth from ``SeedSequence(seed, spawn_key=(crc32(name),
r, 0))`` with r = 0 for a scene with ``fixed_truth`` (the thesis's Test 2:
the same trajectory in every Monte Carlo run), else the run index;
detections and clutter from ``(crc32(name), run, 1)``.

The dataset's `Scenario` describes the walkers for the manifest (one
`Target` per walker: first position, heading, speed, lifetime, a straight
placeholder segment); its truth comes from this simulator, so regenerate a
walker scene with `generate_walkers`, not with `nnda.data.generator`.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from nnda.data.checks import whole_number
from nnda.data.dataset import Dataset, Detections, Truth
from nnda.data.pedestrian.profiles import HeadingProfile, ProfileKind
from nnda.data.pedestrian.terrain import OBSTACLE, SINK, Terrain, TerrainMap, build_terrain
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.sensor import cart_to_polar_at
from nnda.errors import ConfigError, validated
from nnda.files import read_config

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Probability = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]

#: the direction blend of step 2 runs every step (the thesis describes it at waypoints; our default)
BLEND = "every step"
#: a step onto an obstacle or off the map: the walker stays, velocity 0, heading the blend's (our default)
COLLISION = "stay and turn"
#: speeds drawn below this are raised to it (m/s; the thesis does not say how negative draws are handled)
MIN_SPEED_M_S = 0.1
#: the ground radar stands this far south of the map's south edge, at its middle (m; our placement)
RADAR_STANDOFF_M = 10.0
#: the thesis's ground radar (its Sec. 6.2): position std per axis (m), PD, clutter per m^2 over the map
RADAR_SIGMA_M, RADAR_PD, CLUTTER_PER_M2 = 0.25, 0.99, 2e-3


class PersonType(BaseModel):
    """One entry of the thesis's person set A: mean speed and its std (m/s), continuity c in [0, 1]
    (the chance of walking on at a step, on free terrain), and the share of walkers of this type."""

    model_config = _STRICT

    mean_speed_m_s: PositiveFloat
    speed_std_m_s: Annotated[float, Field(ge=0, allow_inf_nan=False)]
    continuity: Probability
    weight: PositiveFloat = 1.0


class Profile(BaseModel):
    """The heading-deviation law of every walker (`nnda.data.pedestrian.profiles`)."""

    model_config = _STRICT

    kind: ProfileKind = "leaf"
    parameter: PositiveFloat = 7.0

    @model_validator(mode="after")
    def _valid(self) -> Profile:
        try:
            HeadingProfile(self.kind, self.parameter)
        except ConfigError as exc:
            raise ValueError(str(exc)) from None
        return self


class Radar(BaseModel):
    """The ground radar: Cartesian fixes of std ``sigma_m`` per axis, detection probability ``pd``, Poisson
    clutter of ``clutter_per_m2`` per m^2 uniform over the map (Frencl (2014), Sec. 6.2)."""

    model_config = _STRICT

    sigma_m: Annotated[float, Field(ge=0, allow_inf_nan=False)] = RADAR_SIGMA_M
    pd: Probability = RADAR_PD
    clutter_per_m2: Annotated[float, Field(ge=0, allow_inf_nan=False)] = CLUTTER_PER_M2


class WalkerScene(BaseModel):
    """A walker scene: map, duration, walkers, births, radar (module docstring for the defaults)."""

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")]
    description: str = ""
    map: TerrainMap
    duration_s: PositiveFloat
    scan_period_s: PositiveFloat = 1.0
    profile: Profile = Profile()
    people: Annotated[list[PersonType], Field(min_length=1)] = [PersonType(mean_speed_m_s=1.5, speed_std_m_s=0.5,
                                                                           continuity=1.0)]
    initial: Annotated[int, Field(ge=0)] = 1
    spawned: Annotated[int, Field(ge=0)] = 0
    spawn_until_s: PositiveFloat | None = None
    birth_rate_per_s: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.0
    fixed_truth: bool = False
    radar: Radar = Radar()
    seed: Annotated[int, Field(ge=0)] = 0

    @model_validator(mode="after")
    def _consistent(self) -> WalkerScene:
        ratio = self.duration_s / self.scan_period_s
        if not math.isclose(ratio, round(ratio), abs_tol=1e-9):
            raise ValueError(f"duration_s = {self.duration_s} is not a whole number of scan periods "
                             f"({self.scan_period_s} s)")
        if self.initial == 0 and self.spawned == 0 and self.birth_rate_per_s == 0:
            raise ValueError("no walker is ever born: give initial, spawned or birth_rate_per_s")
        return self

    @property
    def n_scans(self) -> int:
        return round(self.duration_s / self.scan_period_s)


@dataclass(frozen=True)
class Walks:
    """Simulated truth: rows of (scan, walker) where the walker exists, in scan then walker order, (M,) each;
    per walker (W,): ``birth_step`` (0 = present at time 0), ``kind`` (0 initial, 1 spontaneous, 2 spawned)."""

    scan: np.ndarray
    walker: np.ndarray
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    birth_step: np.ndarray
    kind: np.ndarray


def _streams(name: str, seed: int, run: int, which: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(zlib.crc32(name.encode()), run, which)))


def _birth_schedule(scene: WalkerScene, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Birth step and kind (0 initial, 1 spontaneous, 2 spawned) of every walker, ordered by step then kind."""
    n = scene.n_scans
    spontaneous = rng.poisson(scene.birth_rate_per_s * scene.scan_period_s, n)
    last = n if scene.spawn_until_s is None else max(1, min(n, round(scene.spawn_until_s / scene.scan_period_s)))
    spawn_steps = rng.integers(1, last + 1, scene.spawned)
    steps = np.concatenate([np.zeros(scene.initial, np.int64), np.repeat(np.arange(1, n + 1), spontaneous),
                            spawn_steps])
    kinds = np.concatenate([np.zeros(scene.initial, np.int8), np.ones(int(spontaneous.sum()), np.int8),
                            np.full(scene.spawned, 2, np.int8)])
    order = np.lexsort((kinds, steps))
    return steps[order], kinds[order]


class _Crowd:
    """State of every walker a scene will hold (capacity W), living or not."""

    def __init__(self, scene: WalkerScene, terrain: Terrain, rng: np.random.Generator):
        self.scene, self.terrain, self.rng = scene, terrain, rng
        self.profile = HeadingProfile(scene.profile.kind, scene.profile.parameter)
        self.birth_step, self.kind = _birth_schedule(scene, rng)
        w = self.birth_step.size
        shares = np.array([p.weight for p in scene.people])
        types = rng.choice(len(scene.people), size=w, p=shares / shares.sum())
        self.mean = np.array([p.mean_speed_m_s for p in scene.people])[types]
        self.std = np.array([p.speed_std_m_s for p in scene.people])[types]
        self.continuity = np.array([p.continuity for p in scene.people])[types]
        self.x, self.y, self.heading = np.zeros(w), np.zeros(w), np.zeros(w)
        self.vx, self.vy = np.zeros(w), np.zeros(w)
        self.node = np.zeros(w, np.intp)
        self.goal = np.zeros(w, np.intp)  # the final sink's node
        self.alive = np.zeros(w, bool)
        self.gone = np.zeros(w, bool)

    def _place(self, idx: np.ndarray, from_node: np.ndarray) -> None:
        """Newborns ``idx``: a final sink reachable from ``from_node``, then their first waypoint."""
        t = self.terrain
        reach = t.reach_sink[from_node]  # (n, S)
        pick = (self.rng.random(idx.size) * reach.sum(axis=1)).astype(np.intp)
        self.goal[idx] = t.sink_nodes[np.argmax(np.cumsum(reach, axis=1) > pick[:, None], axis=1)]
        self.node[idx] = from_node
        self._next(idx)

    def _next(self, idx: np.ndarray) -> None:
        """Walkers ``idx`` pick the linked node whose direction best matches their final sink's (dot product)."""
        if idx.size == 0:
            return
        t = self.terrain
        p = np.stack([self.x[idx], self.y[idx]], axis=1)
        to_goal = t.node_xy[self.goal[idx]] - p
        to_goal /= np.maximum(np.linalg.norm(to_goal, axis=1, keepdims=True), 1e-12)
        to_node = t.node_xy[None, :, :] - p[:, None, :]  # (n, N, 2)
        to_node /= np.maximum(np.linalg.norm(to_node, axis=2, keepdims=True), 1e-12)
        score = np.einsum("nkd,nd->nk", to_node, to_goal)
        goal_col = self.goal[idx] - t.sink_nodes[0]
        allowed = t.links[self.node[idx]] & t.reach_sink[:, goal_col].T  # linked, and leading to the goal
        score = np.where(allowed, score, -np.inf)
        has = allowed.any(axis=1)
        self.node[idx] = np.where(has, np.argmax(score, axis=1), self.goal[idx])

    def births(self, step: int) -> None:
        new = np.flatnonzero(self.birth_step == step)
        if new.size == 0:
            return
        t, rng = self.terrain, self.rng
        living = np.flatnonzero(self.alive)
        spawn = (self.kind[new] == 2) & (living.size > 0)
        at_gate = new[~spawn]
        if at_gate.size:
            g = rng.integers(0, len(t.generator_cells), at_gate.size)
            counts = np.array([len(c) for c in t.generator_cells])
            which = (rng.random(at_gate.size) * counts[g]).astype(np.intp)
            offsets = np.concatenate([[0], np.cumsum(counts)])
            all_cells = np.concatenate(t.generator_cells)
            rc = all_cells[offsets[g] + which]
            jitter = rng.random((at_gate.size, 2))
            self.x[at_gate] = (rc[:, 1] + jitter[:, 0]) * t.cell_m
            self.y[at_gate] = (rc[:, 0] + jitter[:, 1]) * t.cell_m
            self.heading[at_gate] = rng.uniform(-np.pi, np.pi, at_gate.size)
            self.alive[at_gate] = True
            self._place(at_gate, t.generator_nodes[g])
        kids = new[spawn]
        if kids.size:
            parent = living[rng.integers(0, living.size, kids.size)]
            self.x[kids], self.y[kids], self.heading[kids] = self.x[parent], self.y[parent], self.heading[parent]
            self.alive[kids] = True
            self._place(kids, self.node[parent])

    def move(self) -> None:
        """One step of every living walker (module docstring, steps 1-5)."""
        idx = np.flatnonzero(self.alive)
        if idx.size == 0:
            return
        t, rng, T = self.terrain, self.rng, self.scene.scan_period_s
        x, y = self.x[idx], self.y[idx]
        target = t.node_xy[self.node[idx]]
        dx, dy = target[:, 0] - x, target[:, 1] - y
        dist = np.hypot(dx, dy)
        reached = (dist <= t.node_radius[self.node[idx]]) & ~t.node_is_sink[self.node[idx]]
        if reached.any():
            self._next(idx[reached])
            target = t.node_xy[self.node[idx]]
            dx, dy = target[:, 0] - x, target[:, 1] - y
            dist = np.hypot(dx, dy)
        u = rng.random((3, idx.size))
        normal = rng.standard_normal(idx.size)
        inv = 1.0 / np.maximum(dist, 1e-12)
        h = self.heading[idx]
        theta = u[0]
        bx = theta * np.cos(h) + (1.0 - theta) * dx * inv
        by = theta * np.sin(h) + (1.0 - theta) * dy * inv
        blend = np.arctan2(by, bx)
        row, col, _ = t.cell_of(x, y)
        moving = u[1] < self.continuity[idx] * t.facility[row, col]
        mean, std = self.mean[idx], self.std[idx]
        speed = np.clip(mean + std * normal, MIN_SPEED_M_S, np.maximum(mean + 3.0 * std, MIN_SPEED_M_S))
        alpha = blend + self.profile.quantile(u[2])
        vx, vy = speed * np.cos(alpha), speed * np.sin(alpha)
        nx, ny = x + vx * T, y + vy * T
        # the step is checked at points every half cell along it, so a thin wall is not jumped over
        n_sub = max(1, math.ceil(float(speed.max()) * T / (0.5 * t.cell_m)))
        f = np.arange(1, n_sub + 1)[:, None] / n_sub
        blocked = (t.kind_at(x + f * (nx - x), y + f * (ny - y)) == OBSTACLE).any(axis=0)
        go = moving & ~blocked
        self.x[idx], self.y[idx] = np.where(go, nx, x), np.where(go, ny, y)
        self.vx[idx], self.vy[idx] = np.where(go, vx, 0.0), np.where(go, vy, 0.0)
        self.heading[idx] = np.where(go, alpha, np.where(blocked, blend, h))

    def leave(self) -> None:
        """Walkers standing in a sink cell leave the scene."""
        idx = np.flatnonzero(self.alive)
        done = idx[self.terrain.kind_at(self.x[idx], self.y[idx]) == SINK]
        self.alive[done] = False
        self.gone[done] = True


def simulate(scene: WalkerScene, terrain: Terrain, rng: np.random.Generator) -> Walks:
    """The walkers of one truth draw of ``scene`` on its built ``terrain`` (`Walks`)."""
    crowd = _Crowd(scene, terrain, rng)
    crowd.births(0)
    parts = []
    for k in range(1, scene.n_scans + 1):
        crowd.move()
        crowd.births(k)
        idx = np.flatnonzero(crowd.alive)
        parts.append((np.full(idx.size, k, np.int32), idx.astype(np.int32), crowd.x[idx], crowd.y[idx],
                      crowd.vx[idx], crowd.vy[idx]))
        crowd.leave()
    cols = [np.concatenate(c) for c in zip(*parts)] if parts else [np.empty(0)] * 6
    return Walks(*cols, crowd.birth_step, crowd.kind)


def _heading_deg(vx: float, vy: float) -> float:
    """A pilot's heading (degrees clockwise from north) of a velocity; 0 when standing."""
    return math.degrees(math.atan2(vx, vy)) % 360.0 if (vx or vy) else 0.0


def radar_sensor(scene: WalkerScene) -> Sensor:
    """The scene's ground radar as an nnda `Sensor` of kind "position" (its clutter config records the mean
    count per scan; the clutter is drawn uniformly over the map rectangle, see `generate_walkers`)."""
    m, r = scene.map, scene.radar
    far = math.hypot(m.width_m / 2, m.height_m + RADAR_STANDOFF_M) + 100.0
    mean = r.clutter_per_m2 * m.width_m * m.height_m
    return Sensor(name="ground-radar", kind="position", x_m=m.width_m / 2, y_m=-RADAR_STANDOFF_M,
                  scan_period_s=scene.scan_period_s, sigma_position_m=r.sigma_m, min_range_m=0.0, max_range_m=far,
                  pd=r.pd, clutter=Clutter(law="square" if mean > 0 else "none", count=round(mean),
                                           count_law="poisson", side_m=max(m.width_m, m.height_m),
                                           centre_m=(m.width_m / 2, m.height_m / 2)))


def _scenario(scene: WalkerScene, walks: Walks, used: np.ndarray) -> Scenario:
    T = scene.scan_period_s
    first = np.searchsorted(walks.walker[np.lexsort((walks.scan, walks.walker))], used)
    order = np.lexsort((walks.scan, walks.walker))
    rows = order[first]
    last_scan = np.zeros(walks.birth_step.size, np.int64)
    np.maximum.at(last_scan, walks.walker, walks.scan)
    targets = []
    for i, (w, r) in enumerate(zip(used.tolist(), rows.tolist())):
        born = walks.birth_step[w] * T
        speed = max(math.hypot(walks.vx[r], walks.vy[r]), MIN_SPEED_M_S)
        targets.append(Target(name=f"walker-{i:04d}", x_m=float(walks.x[r]), y_m=float(walks.y[r]),
                              heading_deg=_heading_deg(float(walks.vx[r]), float(walks.vy[r])), speed_m_s=speed,
                              start_time_s=born, segments=[Segment(duration_s=max(last_scan[w] * T - born, T))]))
    kinds = np.bincount(walks.kind[used], minlength=3)
    if not targets:
        raise ConfigError(f"walker scene {scene.name!r}: no walker lives at any scan")
    return Scenario(name=scene.name, duration_s=scene.duration_s, targets=targets, sensors=(radar_sensor(scene),),
                    process_noise=ProcessNoise(model="none"), seed=scene.seed,
                    description=f"{scene.description} [walkers simulated by nnda.data.pedestrian.walkers: "
                                f"{kinds[0]} initial, {kinds[1]} spontaneous, {kinds[2]} spawned; targets give "
                                f"each walker's start only; clutter Poisson {scene.radar.clutter_per_m2:g} per m^2 "
                                f"over the {scene.map.width_m:g} x {scene.map.height_m:g} m map]".strip())


def _observe(scene: WalkerScene, scenario: Scenario, walks: Walks, tid: np.ndarray,
             rng: np.random.Generator) -> tuple[Detections, Truth]:
    """The radar's view of ``walks``: each walker row detected with probability pd, its fix with Gaussian
    noise; Poisson clutter uniform over the map rectangle; detections in scan then azimuth order."""
    sensor, r, m = scenario.sensors[0], scene.radar, scene.map
    n = walks.scan.size
    detected = rng.random(n) < r.pd
    noise = rng.standard_normal((2, n)) * r.sigma_m
    counts = rng.poisson(r.clutter_per_m2 * m.width_m * m.height_m, scene.n_scans)
    total = int(counts.sum())
    cxy = rng.random((2, total)) * np.array([[m.width_m], [m.height_m]])
    scan = np.concatenate([walks.scan[detected], np.repeat(np.arange(1, scene.n_scans + 1), counts)]).astype(np.int32)
    mx = np.concatenate([(walks.x + noise[0])[detected], cxy[0]])
    my = np.concatenate([(walks.y + noise[1])[detected], cxy[1]])
    target = np.concatenate([tid[detected], np.full(total, -1, np.int32)]).astype(np.int32)
    rng_, az = cart_to_polar_at(sensor.position, mx, my)
    order = np.lexsort((az, scan))
    scan, mx, my, target, rng_, az = (a[order] for a in (scan, mx, my, target, rng_, az))
    time = scan.astype(float) * scene.scan_period_s
    detections = Detections(scan, time, rng_, az, mx, my, target < 0, target, np.zeros(scan.size, np.int32))
    truth = Truth(walks.scan.astype(np.int32), walks.scan * scene.scan_period_s, tid, walks.x.copy(),
                  walks.y.copy(), walks.vx.copy(), walks.vy.copy(), detected)
    return detections, truth


def walker_runs(scene: WalkerScene, runs: Iterable[int], seed: int | None = None) -> Iterator[Dataset]:
    """Runs of one walker scene (a Monte Carlo set); ``seed`` defaults to the scene's own."""
    seed = whole_number(scene.seed if seed is None else seed, "seed")
    terrain = build_terrain(scene.map, f"walker scene {scene.name!r}")
    fixed: tuple[Walks, Scenario, np.ndarray] | None = None
    for run in runs:
        run = whole_number(run, "run")
        if fixed is None or not scene.fixed_truth:
            walks = simulate(scene, terrain, _streams(scene.name, seed, 0 if scene.fixed_truth else run, 0))
            used = np.unique(walks.walker)
            tid = np.searchsorted(used, walks.walker).astype(np.int32)
            fixed = (walks, _scenario(scene.model_copy(update={"seed": seed}), walks, used), tid)
        walks, scenario, tid = fixed
        detections, truth = _observe(scene, scenario, walks, tid, _streams(scene.name, seed, run, 1))
        yield Dataset(scenario, seed, run, detections, truth)


def generate_walkers(scene: WalkerScene, seed: int | None = None, run: int = 0) -> Dataset:
    """One run of a walker scene as an nnda `Dataset` (truth per walker per scan, the ground radar's fixes)."""
    return next(walker_runs(scene, [run], seed))


def is_walker_config(data: dict) -> bool:
    """Does a config mapping describe a walker scene (it has a ``map``) rather than a scripted scenario?"""
    return isinstance(data, dict) and "map" in data


def load_walker_scene(path: str | Path) -> WalkerScene:
    """Read a walker scene (``.toml`` or ``.json``: the fields of `WalkerScene`); its ``map`` is a table or
    the path of a map file, relative to the scene's file. Errors name the file and the field or place."""
    path = Path(path)
    data = read_config(path, "walker scene")
    where = str(path)
    if isinstance(data.get("map"), str):
        map_path = path.parent / data["map"]
        data = {**data, "map": validated(TerrainMap, read_config(map_path, "terrain map"), str(map_path),
                                         "terrain map")}
        where = str(map_path)
    scene = validated(WalkerScene, data, str(path), "walker scene")
    build_terrain(scene.map, where)  # the map's checks, naming its file
    return scene
