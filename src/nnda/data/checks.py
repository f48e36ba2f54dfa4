"""Checks of a scenario before it is generated: its size, its clutter against the coverage, its targets.

A scenario is validated data (`nnda.data.scenario`), but a valid one can
still be unworkable or implausible. Three checks run before any draw
(`nnda.data.generator.check_scenario` runs all three; `generate` the first
two):

* **size**: `estimate_size` bounds the detections of one dataset from the
  config alone (per sensor: sweeps x (targets alive + expected clutter per
  sweep)) and `check_size` refuses more than ``max_detections`` (default
  `MAX_DETECTIONS`, about 2.7 GB of detection columns) with a ConfigError
  giving the number and how to raise the limit. It is arithmetic on the
  config: 1e7 scans, a 1e-6 s period or 1e8 clutter points per sweep fail in
  microseconds, before anything is allocated.
* **clutter**: clutter points outside a sensor's coverage are redrawn until
  inside (`nnda.data.clutter`), so a clutter region that the coverage
  barely meets would draw for ever. `clutter_inside_fraction` measures
  the share of a square or Gaussian region inside the coverage on a fixed
  grid, and `check_clutter` refuses less than `MIN_CLUTTER_INSIDE`, naming
  the scenario and the sensor.
* **plausibility** (warnings, not errors): `target_warnings` names a target
  faster than `MAX_SPEED_M_S`, one starting after the scenario's end, one
  that exists at no sweep, and one whose noise-free track never enters the
  coverage of the sensor sweeping.

`whole_number` is the check of a seed, a run index or a count, wherever one
arrives (generator arguments, dataset manifests).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri

from nnda.data.scenario import Clutter, Scenario, Sensor, Target
from nnda.data.sensor import in_coverage
from nnda.errors import ConfigError, NndaError

#: detections one dataset may hold unless the caller raises it (``--max-detections``, ``max_detections=``)
MAX_DETECTIONS = 50_000_000
#: bytes per row of the detection columns (scan, time, range, azimuth, x, y, is_clutter, target_id, sensor)
DETECTION_BYTES = 4 + 8 * 5 + 1 + 4 + 4
#: bytes per row of the truth columns (scan, time, target_id, x, y, vx, vy, detected)
TRUTH_BYTES = 4 + 8 + 4 + 8 * 4 + 1
#: the least share of a square or Gaussian clutter region that must lie inside its sensor's coverage
MIN_CLUTTER_INSIDE = 1e-3
#: grid points per axis on which `clutter_inside_fraction` measures that share
CLUTTER_GRID = 200
#: a target faster than this (m/s, at any point of its trajectory) is reported as implausible
MAX_SPEED_M_S = 1_000.0


def whole_number(value: object, what: str, least: int = 0, error: type[NndaError] = ConfigError) -> int:
    """``value`` as an int if it is a whole number >= ``least`` (not a bool, a float or a string); ``error``
    naming ``what`` (a parameter, a manifest field) otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise error(f"{what} is {value!r}; it must be a whole number >= {least}")
    return int(value)


@dataclass(frozen=True)
class SizeEstimate:
    """Upper bounds of one dataset's size from its config: ``truth_rows`` (one per target alive at a
    sweep) bounds the target detections, ``clutter`` is the expected number of clutter points."""

    scans: int
    truth_rows: int
    clutter: int

    @property
    def detections(self) -> int:
        return self.truth_rows + self.clutter

    @property
    def bytes(self) -> int:
        """Bytes of the detection and truth columns (the files are about this size; generating needs a few
        times more while the arrays are built)."""
        return self.detections * DETECTION_BYTES + self.truth_rows * TRUTH_BYTES


def _sweeps_alive(sensor: Sensor, duration_s: float, start_s: float, life_s: float) -> int:
    """Upper bound of a sensor's sweeps in (0, duration_s] that fall within [start_s, start_s + life_s]."""
    if start_s > duration_s:
        return 0
    return min(sensor.n_sweeps(duration_s), int(life_s // sensor.scan_period_s) + 1)


def estimate_size(scenario: Scenario) -> SizeEstimate:
    """`SizeEstimate` of one run of ``scenario``, from its config only (no trajectory is evaluated)."""
    truth_rows = clutter = 0
    for sensor in scenario.sensors:
        truth_rows += sum(_sweeps_alive(sensor, scenario.duration_s, t.start_time_s, t.duration_s)
                          for t in scenario.targets)
        if sensor.clutter.law != "none":
            clutter += sensor.n_sweeps(scenario.duration_s) * sensor.clutter.count
    return SizeEstimate(scenario.n_scans, truth_rows, clutter)


def check_size(scenario: Scenario, max_detections: int = MAX_DETECTIONS) -> SizeEstimate:
    """`estimate_size`, or a ConfigError naming the scenario, the estimate and the way to raise the limit."""
    whole_number(max_detections, "max_detections", least=1)
    size = estimate_size(scenario)
    if size.detections > max_detections:
        clutter = {s.clutter.count if s.clutter.law != "none" else 0 for s in scenario.sensors}
        per_sweep = f"{clutter.pop():,}" if len(clutter) == 1 else "sensor-dependent"
        raise ConfigError(
            f"scenario {scenario.name!r}: one dataset would hold up to {size.detections:,} detections "
            f"({size.scans:,} scans, {len(scenario.targets)} target(s), {per_sweep} clutter points per sweep; "
            f"about {size.bytes / 1e9:.3g} GB), above the limit of {max_detections:,}; shorten duration_s, "
            f"lengthen scan_period_s or lower clutter.count, or raise the limit with --max-detections "
            f"(nnda generate) or max_detections= (nnda.data.generator.generate)")
    return size


def _grid(clutter: Clutter, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CLUTTER_GRID^2 points (x, y in m) with equal shares of a square or Gaussian clutter law's mass."""
    u = (np.arange(CLUTTER_GRID) + 0.5) / CLUTTER_GRID
    if clutter.law == "square":
        axis = (u - 0.5) * clutter.side_m
    else:  # gaussian: the quantiles of each axis
        axis = ndtri(u) * clutter.sigma_m
    gx, gy = np.meshgrid(axis + centre[0], axis + centre[1])
    return gx.ravel(), gy.ravel()


def clutter_inside_fraction(clutter: Clutter, sensor: Sensor, centre: np.ndarray) -> float:
    """Share (0..1) of a sensor's clutter law inside its coverage; ``centre`` (2,) m is the region's centre.

    Square and Gaussian laws are measured on `CLUTTER_GRID`^2 points of equal
    mass (a grid over the square; the product of each axis's quantiles);
    an annulus lies inside by construction (1.0); no clutter counts as 1.0.
    """
    if clutter.law in ("annulus", "none") or clutter.count == 0:
        return 1.0
    return float(in_coverage(sensor, *_grid(clutter, centre)).mean())


def check_clutter(scenario: Scenario, centres: np.ndarray) -> None:
    """ConfigError naming the scenario and sensor whose clutter region lies (almost) outside its coverage.

    ``centres`` (n_sensors, 2) m are the clutter centres of the sensors
    (`nnda.data.generator.Plan.clutter_centre`).
    """
    for sensor, centre in zip(scenario.sensors, centres):
        inside = clutter_inside_fraction(sensor.clutter, sensor, centre)
        if inside >= MIN_CLUTTER_INSIDE:
            continue
        c = sensor.clutter
        region = f"side {c.side_m:g} m" if c.law == "square" else f"sigma {c.sigma_m:g} m"
        sector = "" if sensor.full_circle else f", sector {sensor.boresight_deg:g} +- {sensor.fov_deg / 2:g} deg"
        raise ConfigError(
            f"scenario {scenario.name!r}: clutter of sensor {sensor.name!r}: the {c.law} region ({region}, centred "
            f"at ({centre[0]:.0f}, {centre[1]:.0f}) m) has {inside:.2%} of its points inside the coverage of the "
            f"sensor at ({sensor.x_m:.0f}, {sensor.y_m:.0f}) m ({sensor.min_range_m:.0f}-{sensor.max_range_m:.0f} m"
            f"{sector}); at least {MIN_CLUTTER_INSIDE:.1%} must be, as clutter outside it is redrawn. Move "
            f"clutter.centre_m, widen the region or use law = \"annulus\"")


def _top_speed(target: Target) -> float:
    """Highest speed (m/s) of a target's trajectory: speed changes linearly within a segment."""
    speed = top = target.speed_m_s
    for seg in target.segments:
        speed += seg.tangential_accel * seg.duration_s
        top = max(top, speed)
    return top


def target_warnings(scenario: Scenario, target_id: np.ndarray, sensor: np.ndarray, x: np.ndarray,
                    y: np.ndarray) -> list[str]:
    """One line per implausible target of ``scenario``, naming it, and per sensor of several that sees no
    target at all; empty when everything is plausible.

    The arrays (M,) are the noise-free truth rows (`nnda.data.generator.Plan`):
    target index, index of the sensor sweeping the row's scan, position in m.
    """
    covered = np.zeros(x.size, dtype=bool)
    for j, s in enumerate(scenario.sensors):
        rows = sensor == j
        covered[rows] = in_coverage(s, x[rows], y[rows])
    lines = []
    for j, s in enumerate(scenario.sensors):
        if len(scenario.sensors) > 1 and (sensor == j).any() and not covered[sensor == j].any():
            lines.append(f"scenario {scenario.name!r}: sensor {s.name!r} sees no target at any of its sweeps "
                         f"(its coverage misses every target): its scans hold clutter only")
    for tid, target in enumerate(scenario.targets):
        name = f"scenario {scenario.name!r}: target {target.name!r}"
        top = _top_speed(target)
        if top > MAX_SPEED_M_S:
            lines.append(f"{name} reaches {top:,.0f} m/s, faster than {MAX_SPEED_M_S:,.0f} m/s")
        mine = target_id == tid
        if target.start_time_s > scenario.duration_s:
            lines.append(f"{name} starts at {target.start_time_s:g} s, after the scenario's end "
                         f"({scenario.duration_s:g} s): it has no scan")
        elif not mine.any():
            lines.append(f"{name} exists at no sweep ({target.start_time_s:g}-"
                         f"{target.start_time_s + target.duration_s:g} s falls between sweeps)")
        elif not covered[mine].any():
            lines.append(f"{name} is outside the coverage of the sensor sweeping at each of its "
                         f"{int(mine.sum())} sweep(s): it is never detected")
    return lines
