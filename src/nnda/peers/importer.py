"""Data nobody here generated: a scene simulated by Stone Soup, written as an nnda dataset.

`simulate` runs Stone Soup's `MultiTargetGroundTruthSimulator` (targets born
and dying at random, each moving by its near-constant-velocity model) and
`SimpleDetectionSimulator` (detection with probability P_D through the
radar's polar model, Poisson clutter uniform in azimuth and range over the
coverage), every random draw seeded from one seed. The result is an nnda
`Dataset`: contacts sorted by scan then azimuth, truth per target per scan,
and a `Scenario` whose targets give each path's first state (position,
heading, speed, start time) for reference; the motion itself is in the
truth. Our trackers read it like any other dataset (`nnda compare` with a
``path`` scenario).

Requires Stone Soup (``pip install 'nnda[peers]'``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
from stonesoup.simulator.simple import MultiTargetGroundTruthSimulator, SimpleDetectionSimulator
from stonesoup.types.detection import TrueDetection
from stonesoup.types.state import GaussianState

from nnda.data.dataset import Dataset, Detections, Truth, write_dataset
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.sensor import in_coverage_polar, polar_to_cart, wrap_azimuth
from nnda.errors import ConfigError
from nnda.peers.adapter import measurement_model, to_datetime, to_seconds


@dataclass(frozen=True)
class StoneSoupScene:
    """What Stone Soup simulates; every length in m, speed in m/s, time in scans of ``sensor.scan_period_s``.

    Targets start from a Gaussian around ``position_m`` (x, y) with std
    ``position_sigma_m`` per axis and velocity around ``velocity_m_s`` (vx,
    vy) with std ``velocity_sigma_m_s``; ``targets`` exist at scan 1 and
    ``birth_rate`` more per scan are born (Poisson), each dying with
    ``death_probability`` per scan. Motion: Stone Soup's ConstantVelocity
    with q = ``sigma_accel``^2 T (m^2/s^3) per axis. ``clutter`` is the mean
    Poisson count per scan. Detection probability and noise are the sensor's.
    """

    n_scans: int = 60
    targets: int = 4
    birth_rate: float = 0.02
    death_probability: float = 0.002
    position_m: tuple[float, float] = (-6_000.0, 15_000.0)
    position_sigma_m: float = 4_000.0
    velocity_m_s: tuple[float, float] = (120.0, 0.0)
    velocity_sigma_m_s: float = 30.0
    sigma_accel: float = 1.0
    clutter: float = 100.0
    sensor: Sensor = Sensor(pd=0.9)

    def check(self) -> None:
        """ConfigError on values Stone Soup would not simulate meaningfully."""
        bad = [name for name, ok in (
            ("n_scans >= 1", self.n_scans >= 1), ("targets >= 0", self.targets >= 0),
            ("birth_rate >= 0", self.birth_rate >= 0),
            ("0 <= death_probability <= 1", 0 <= self.death_probability <= 1),
            ("position_sigma_m >= 0", self.position_sigma_m >= 0),
            ("velocity_sigma_m_s >= 0", self.velocity_sigma_m_s >= 0),
            ("sigma_accel >= 0", self.sigma_accel >= 0), ("clutter >= 0", self.clutter >= 0),
        ) if not ok]
        if bad:
            raise ConfigError(f"Stone Soup scene: need {', '.join(bad)}")


def simulate(scene: StoneSoupScene = StoneSoupScene(), seed: int = 0, name: str = "stonesoup") -> Dataset:
    """Simulate ``scene`` with Stone Soup (all draws from ``seed``) and return it as an nnda Dataset."""
    scene.check()
    sensor, T = scene.sensor, scene.sensor.scan_period_s
    seeds = [int(s) for s in np.random.SeedSequence(seed).generate_state(4) % 2**31]
    q = scene.sigma_accel ** 2 * T
    motion = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)], seed=seeds[0])
    (x0, y0), (vx0, vy0) = scene.position_m, scene.velocity_m_s
    ps, vs = scene.position_sigma_m ** 2, scene.velocity_sigma_m_s ** 2
    truth_sim = MultiTargetGroundTruthSimulator(
        transition_model=motion, initial_state=GaussianState([[x0], [vx0], [y0], [vy0]], np.diag([ps, vs, ps, vs]),
                                                             timestamp=to_datetime(T)),
        timestep=to_datetime(2 * T) - to_datetime(T), number_steps=scene.n_scans, birth_rate=scene.birth_rate,
        death_probability=scene.death_probability, initial_number_targets=scene.targets, seed=seeds[1])
    detect_sim = SimpleDetectionSimulator(
        groundtruth=truth_sim, measurement_model=measurement_model(sensor, seed=seeds[2]),
        detection_probability=sensor.pd,
        meas_range=np.array([[-math.pi, math.pi], [sensor.min_range_m, sensor.max_range_m]]),
        clutter_rate=scene.clutter, seed=seeds[3])
    paths: dict = {}  # GroundTruthPath -> target id, in order of birth
    det_rows, truth_rows = [], []
    for when, detections in detect_sim:
        k = round(to_seconds(when) / T)
        for path in truth_sim.groundtruth_paths:
            paths.setdefault(path, len(paths))
        seen = set()
        for d in detections:
            az, r = float(wrap_azimuth(float(d.state_vector[0, 0]))), float(d.state_vector[1, 0])
            tid = paths[d.groundtruth_path] if isinstance(d, TrueDetection) else -1
            if not in_coverage_polar(sensor, np.array(r), np.array(az)):
                continue
            det_rows.append((k, az, r, tid))
            seen.add(tid)
        for path in truth_sim.groundtruth_paths:
            s = np.asarray(path.state_vector, float).ravel()
            truth_rows.append((k, paths[path], s[0], s[2], s[1], s[3], paths[path] in seen))
    if not paths:
        raise ConfigError("Stone Soup scene: no target was simulated; raise targets or birth_rate")
    return Dataset(_scenario(scene, paths, name, seed), seed, 0, _detections(det_rows, T), _truth(truth_rows, T))


def import_stonesoup(out: str | Path, scene: StoneSoupScene = StoneSoupScene(), seed: int = 0,
                     overwrite: bool = False) -> Path:
    """Simulate ``scene`` with Stone Soup and write it as an nnda dataset directory at ``out``."""
    out = Path(out)
    return write_dataset(simulate(scene, seed, name=out.name or "stonesoup"), out, overwrite)


def _detections(rows: list[tuple], T: float) -> Detections:
    a = np.array(rows, dtype=float).reshape(-1, 4)
    a = a[np.lexsort((a[:, 1], a[:, 0]))]
    x, y = polar_to_cart(a[:, 2], a[:, 1])
    tid = a[:, 3].astype(np.int32)
    return Detections(scan=a[:, 0].astype(np.int32), time=a[:, 0] * T, range=a[:, 2], azimuth=a[:, 1],
                      x=x, y=y, is_clutter=tid < 0, target_id=tid)


def _truth(rows: list[tuple], T: float) -> Truth:
    scan, tid, x, y, vx, vy, det = (np.array(c) for c in zip(*rows))
    order = np.lexsort((tid, scan))
    return Truth(scan=scan[order].astype(np.int32), time=scan[order] * T, target_id=tid[order].astype(np.int32),
                 x=x[order], y=y[order], vx=vx[order], vy=vy[order], detected=det[order].astype(bool))


def _scenario_name(name: str) -> str:
    """``name`` as a scenario name: ASCII letters, digits, '_', '.', '-' kept, anything else and a leading
    dot replaced by '_'."""
    kept = "".join(c if (c.isascii() and c.isalnum()) or c in "_.-" else "_" for c in name)
    return "_" + kept[1:] if kept.startswith(".") else kept


def _scenario(scene: StoneSoupScene, paths: dict, name: str, seed: int) -> Scenario:
    T = scene.sensor.scan_period_s
    targets = []
    for path, i in paths.items():
        first = path.states[0]
        x, vx, y, vy = np.asarray(first.state_vector, float).ravel()
        targets.append(Target(
            name=f"ss{i}", x_m=x, y_m=y, heading_deg=math.degrees(math.atan2(vx, vy)) % 360.0,
            speed_m_s=max(math.hypot(vx, vy), 1e-6), start_time_s=to_seconds(first.timestamp),
            segments=[Segment(duration_s=max(T, (len(path.states) - 1) * T))]))
    return Scenario(
        name=_scenario_name(name), seed=seed,
        description=(f"simulated by Stone Soup (seed {seed}): {scene.targets} targets at start, birth rate "
                     f"{scene.birth_rate}/scan, death probability {scene.death_probability}/scan, "
                     f"ConstantVelocity motion with sigma_accel {scene.sigma_accel} m/s^2; "
                     f"Poisson clutter, mean {scene.clutter}/scan, uniform in azimuth and range over the "
                     f"coverage; targets below give each path's first state, the truth file its motion"),
        duration_s=scene.n_scans * T, targets=targets, sensor=scene.sensor,
        clutter=Clutter(law="annulus", count=round(scene.clutter), count_law="poisson"),
        process_noise=ProcessNoise(model="none"))
