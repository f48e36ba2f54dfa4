"""The reference scenarios as ready-made configs: the radar scenes of Vargas Avila (2015), Sec. 5.2, and more.

* ``train01`` .. ``train17``: the thesis's 17 single-target training
  scenarios with their gap tables (Tables 5.1-5.11) and our placements (the
  thesis gives starting points and headings only in figures);
* ``T1`` .. ``T7``: each validation trajectory alone, 200 s, no gaps;
* ``S1`` .. ``S6``: the multi-target validation scenarios with Tables 5.12/5.13;
* ``two-radars`` (no counterpart in the thesis): two polar radars 20 km apart
  with overlapping 120-degree sectors and four targets crossing both;
* ``harbour``, ``harbour-dense``: the two radars of Lima (2022) over a
  harbour and its five ships, one hidden from a radar by a larger one (2 and
  50 clutter points per sweep);
* ``ais-harbour`` (ours): ten ships seen by a stream of asynchronous
  position reports (AIS), grouped in 10 s windows.

Training presets use our calibrated clutter (100 points per scan, uniform
in a 16.6 km square on the target's bounding box, which gives the thesis's
share of clutter among the training pairs); validation presets keep 100
points per scan in a square fitted to their targets (see
`_fitted_clutter`). Groups ``train``, ``trajectories`` and ``validation``
name the thesis's sets, ``multisensor`` the scenes with several sensors.
Trajectories are data: (initial speed m/s, [(duration s, a_t m/s^2,
a_n m/s^2), ...]) with positive a_n a right turn (our convention: the
thesis does not say).
"""

from __future__ import annotations

import math

import numpy as np

from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.trajectory import evaluate
from nnda.errors import ConfigError

Trajectory = tuple[float, list[tuple[float, float, float]]]

# --- training trajectories TR1-TR12 (the thesis's "Trajectory 1-12") ---------------------------
TRAINING_TRAJECTORIES: dict[str, Trajectory] = {
    "TR1": (99.0, [(50, 0, 0), (26, 5, 0)]),
    "TR2": (99.0, [(80, 0, 0), (100, 0, 5), (80, 0, 0)]),
    "TR3": (85.0, [(100, 0, 3)]),
    "TR4": (150.0, [(50, 0, 0), (36, 0, 13), (36, 0, -13), (40, 0, 6)]),
    "TR5": (85.0, [(30, 3, 5)]),
    "TR6": (85.0, [(30, 4, 0), (30, -4, 0)]),
    "TR7": (85.0, [(30, 4, 0), (50, 0, 10.33), (40, 0, 12.88)]),
    "TR8": (141.4, [(40, 0, 0), (50, 0, -10), (50, 0, -5)]),
    "TR9": (108.17, [(200, 0, 3.48)]),
    "TR10": (127.28, [(120, 0, -6.6)]),
    "TR11": (113.14, [(100, 0, 0), (50, 0, -5)]),  # -5 m/s^2: the printed rate has no sign
    "TR12": (160.0, [(40, 0, 11.2), (40, 0, -11.2), (40, 0, 13)]),
}

# --- gap tables (the thesis's Tables 5.1-5.11; scan k is at t = 2k s) ----------------------------
_G5_1 = [7, 8, 15, 16, 17, 24, 25, 30, 36, 37, 38]
_G5_3 = _G5_1 + [42, 43, 47]
G8 = _G5_3 + [51, 52, 53]
GAP_TABLES: dict[str, list[int]] = {
    "none": [],
    "5.1": _G5_1,
    "5.2": _G5_1 + [42, 43, 47, 51, 52, 53, 100, 101, 102, 115],
    "5.3": _G5_3,
    "G8": G8,
    "5.5": [7, 8, 15, 16, 17, 24, 25],
    "5.8": G8 + [63, 64, 65, 71, 72, 85],
    "scenario9": [7, 8],
}

# (trajectory, x0 m, y0 m, heading deg clockwise from north, gap table) per training scenario
TRAINING_SCENARIOS: list[tuple[str, float, float, float, str]] = [
    ("TR1", -8000, 10000, 45, "none"),
    ("TR1", 6000, -14000, 315, "5.1"),
    ("TR2", -16000, -12000, 45, "5.2"),
    ("TR2", 16000, -10000, 0, "5.2"),
    ("TR3", -12000, -8000, 45, "5.3"),
    ("TR4", -20000, -10000, 45, "G8"),
    ("TR4", 4000, -22000, 315, "G8"),
    ("TR5", 10000, 10000, 45, "none"),
    ("TR5", -14000, 12000, 135, "scenario9"),
    ("TR6", 14000, -6000, 315, "5.5"),
    ("TR7", -10000, -14000, 45, "G8"),
    ("TR8", -6000, -16000, 45, "G8"),
    ("TR8", 14000, 12000, 200, "G8"),
    ("TR9", -16000, 2000, 45, "5.8"),
    ("TR10", 12000, -12000, 45, "G8"),
    ("TR11", -6000, -20000, 45, "G8"),
    ("TR12", -16000, -8000, 45, "G8"),
]

# --- validation trajectories T1-T7 (T1's third section: 50 s, a length the thesis omits) ---------
VALIDATION_TRAJECTORIES: dict[str, Trajectory] = {
    "T1": (70.7, [(50, 0, 0), (50, 0, 4.94), (50, 0, -4.94), (20, 3, 0)]),
    "T2": (141.4, [(150, 0, 0)]),
    "T3": (196.0, [(60, 0, 10.3)]),
    "T4": (103.0, [(150, 0, 0)]),
    "T5": (85.0, [(20, 5, 0), (45, 0, 6.44), (50, 0, 0)]),
    "T6": (70.7, [(90, 0, 1.24), (90, 0, -1.24)]),
    "T7": (85.0, [(20, 5, 0), (45, 0, -6.44), (50, 0, 0)]),
}

# placements (trajectory, x0, y0, heading; ours) keyed by the name the target takes in a scenario
PLACEMENTS: dict[str, tuple[str, float, float, float]] = {
    "T1": ("T1", -12000, -6000, 45),
    "T2.1": ("T2", -20000, -6000, 45),
    "T2.2": ("T2", 8000, -18000, 315),
    "T2": ("T2", -16000, -10000, 90),  # T2 in S6 (and alone)
    "T3a": ("T3", 6000, 12000, 90),
    "T3b": ("T3", -6000, 14000, 90),
    "T3c": ("T3", 14000, -4000, 180),
    "T4": ("T4", -18000, 6000, 90),
    "T5": ("T5", -12000, -14000, 45),
    "T6": ("T6", 2000, -22000, 45),
    "T7": ("T7", -12200, -13800, 45),
}

# validation scenarios: targets with their gaps (Tables 5.12 and 5.13), 200 s each
VALIDATION_SCENARIOS: dict[str, tuple[str, dict[str, list[int]]]] = {
    "S1": ("T1, two T2 and T3: four targets, no gaps", {"T1": [], "T2.1": [], "T2.2": [], "T3a": []}),
    "S2": ("T4, T5, T6, T7 (T5/T7 start 280 m apart): four targets, no gaps",
           {"T4": [], "T5": [], "T6": [], "T7": []}),
    "S3": ("S2 with the detection gaps of Table 5.12",
           {"T4": [], "T5": [24, 25, 40, 41, 42], "T6": [15, 25, 26, 27, 85, 86], "T7": [8, 50, 51]}),
    "S4": ("T1, two T3 and T5: four targets, no gaps", {"T1": [], "T3a": [], "T3b": [], "T5": []}),
    "S5": ("S4 with the detection gaps of Table 5.13",
           {"T1": [10, 20, 21, 47, 58, 59, 60], "T3a": [11, 12, 24], "T3b": [9, 16, 17], "T5": []}),
    "S6": ("T1, T2, three T3 and T5: six targets, no gaps",
           {"T1": [], "T2": [], "T3a": [], "T3b": [], "T3c": [], "T5": []}),
}
VALIDATION_DURATION_S = 200.0

#: Clutter of the validation presets. The 16.6 km square is calibrated on
#: single-target training scenes only; the validation targets spread over
#: up to 30 km, so these presets keep 100 uniform points per scan but size the
#: square to the targets' noise-free bounding box plus this margin on each side,
#: so every target flies through clutter.
VALIDATION_CLUTTER_MARGIN_M = 2_000.0


def _target(name: str, trajectory: Trajectory, x: float, y: float, heading: float,
            gaps: list[int]) -> Target:
    speed, sections = trajectory
    return Target(
        name=name, x_m=x, y_m=y, heading_deg=heading, speed_m_s=speed, missed_scans=gaps,
        segments=[Segment(duration_s=d, tangential_accel=at, normal_accel=an or None)
                  for d, at, an in sections],
    )


def _training(i: int) -> Scenario:
    traj, x, y, heading, gaps = TRAINING_SCENARIOS[i - 1]
    target = _target(traj, TRAINING_TRAJECTORIES[traj], x, y, heading, GAP_TABLES[gaps])
    gap_note = "no gaps" if gaps == "none" else f"gaps of table {gaps}"
    return Scenario(
        name=f"train{i:02d}", duration_s=target.duration_s, targets=[target], seed=i,
        description=f"training scenario {i}: {traj}, {target.duration_s:.0f} s, {gap_note}",
    )


def _fitted_clutter(targets: list[Target]) -> Clutter:
    """Square clutter covering the targets' bounding box plus the margin (side rounded up to
    100 m), never smaller than the calibrated default square."""
    xs, ys = [], []
    for t in targets:
        st = evaluate(t, np.linspace(0.0, t.duration_s, 401))
        xs.append(st.x)
        ys.append(st.y)
    x, y = np.concatenate(xs), np.concatenate(ys)
    extent = max(np.ptp(x), np.ptp(y)) + 2 * VALIDATION_CLUTTER_MARGIN_M
    return Clutter(side_m=max(Clutter().side_m, 100.0 * math.ceil(extent / 100.0)))


def _validation(name: str) -> Scenario:
    description, members = VALIDATION_SCENARIOS[name]
    targets = []
    for tname, gaps in members.items():
        traj, x, y, heading = PLACEMENTS[tname]
        targets.append(_target(tname, VALIDATION_TRAJECTORIES[traj], x, y, heading, gaps))
    return Scenario(name=name, description=f"validation scenario {name}: {description}",
                    duration_s=VALIDATION_DURATION_S, targets=targets, clutter=_fitted_clutter(targets),
                    seed=100 + int(name[1:]))


#: placement of each validation trajectory when it flies alone
ALONE = {"T1": "T1", "T2": "T2.1", "T3": "T3a", "T4": "T4", "T5": "T5", "T6": "T6", "T7": "T7"}


def _trajectory(name: str) -> Scenario:
    traj, x, y, heading = PLACEMENTS[ALONE[name]]
    target = _target(name, VALIDATION_TRAJECTORIES[traj], x, y, heading, [])
    return Scenario(name=name, description=f"validation trajectory {name} alone, 200 s, no gaps",
                    duration_s=VALIDATION_DURATION_S, targets=[target], clutter=_fitted_clutter([target]),
                    seed=200 + int(name[1:]))


# --- two radars (no counterpart in the reference works) ---------------------------------------
#: the radars 20 km apart on the east-west axis, each looking across the other's side of north, so
#: both sectors wrap through north and overlap north of the baseline; the east radar sweeps 1 s after
#: the west one, so the scans alternate every second
TWO_RADARS = (
    Sensor(name="west", x_m=-10_000.0, y_m=0.0, boresight_deg=30.0, fov_deg=120.0, pd=0.9,
           clutter=Clutter(law="annulus", count=100)),
    Sensor(name="east", x_m=10_000.0, y_m=0.0, boresight_deg=330.0, fov_deg=120.0, scan_offset_s=1.0, pd=0.85,
           sigma_range_m=20.0, sigma_azimuth_mrad=2.0, clutter=Clutter(law="annulus", count=100)),
)
# (name, x0 m, y0 m, heading deg, speed m/s, [(duration s, a_n m/s^2), ...]): each leaves one sector for a while
TWO_RADAR_TARGETS: list[tuple[str, float, float, float, float, list[tuple[float, float]]]] = [
    ("southbound", 0.0, 27_000.0, 180.0, 110.0, [(180, 0.0)]),
    ("eastbound", -22_000.0, 15_000.0, 90.0, 150.0, [(180, 0.0)]),
    ("left-turner", 12_000.0, 26_000.0, 225.0, 120.0, [(60, 0.0), (60, -4.0), (60, 0.0)]),
    ("right-turner", -6_000.0, 8_000.0, 30.0, 90.0, [(100, 0.0), (80, 3.0)]),
]


def _two_radars() -> Scenario:
    targets = [Target(name=name, x_m=x, y_m=y, heading_deg=heading, speed_m_s=speed,
                      segments=[Segment(duration_s=d, normal_accel=an or None) for d, an in sections])
               for name, x, y, heading, speed, sections in TWO_RADAR_TARGETS]
    return Scenario(name="two-radars", duration_s=180.0, targets=targets, sensors=TWO_RADARS, seed=301,
                    description="two radars 20 km apart (west T = 2 s, east 1 s later; 120-degree sectors across "
                                "north), four targets crossing both coverages, 100 clutter points per sweep")


# --- the harbour of Lima (2022), Ch. 4, Tables 4.1-4.3 ---------------------------------------------
KNOT_M_S = 1852.0 / 3600.0
#: the thesis's two radars staring into the harbour. Its sector angles fit no one convention, so the
#: boresights are our reconstruction (146 and -40 degrees counter-clockwise from east, as compass
#: bearings 304 and 130 degrees): each 90-degree sector holds all five ships at the start. Table 4.3: 12 km
#: range, 25 m and 0.5 degree taken as standard deviations, PD 0.9. Named defaults where the thesis is
#: silent: T = 1 s, radar 2 half a period after radar 1 (so every scan has its own time), a 50 m blind range,
#: Poisson clutter of mean 2 per sweep uniform over the sector (the density 2e-8 read per m^2 over the
#: sector is about 2.3 per scan).
HARBOUR_RADARS = (
    Sensor(name="radar1", x_m=7_380.0, y_m=-236.0, boresight_deg=304.0, fov_deg=90.0, scan_period_s=1.0,
           sigma_range_m=25.0, sigma_azimuth_mrad=1e3 * math.radians(0.5), min_range_m=50.0, max_range_m=12_000.0,
           pd=0.9, clutter=Clutter(law="annulus", count=2, count_law="poisson")),
    Sensor(name="radar2", x_m=-4_000.0, y_m=9_000.0, boresight_deg=130.0, fov_deg=90.0, scan_period_s=1.0,
           scan_offset_s=0.5, sigma_range_m=25.0, sigma_azimuth_mrad=1e3 * math.radians(0.5), min_range_m=50.0,
           max_range_m=12_000.0, pd=0.9, clutter=Clutter(law="annulus", count=2, count_law="poisson")),
)
#: Table 4.2: (name, x0 m, y0 m, heading deg, speed kn, turn radius m or None, length m). The thesis gives
#: neither the heading reference nor the turn direction: headings are read as compass bearings and both
#: circles turn right. Lengths are ours (the thesis has none): ship 2 is the large vessel that hides the small
#: ship 3 from radar 2 for about 49 of the 200 scans (its Fig. 4.5); radar 1 sees ship 3 throughout. Ship 4
#: leaves radar 1's 12 km range after about 64 s, so part of the scene has one radar only.
HARBOUR_SHIPS: list[tuple[str, float, float, float, float, float | None, float]] = [
    ("ship1", 3_150.0, 7_400.0, 130.0, 20.0, 200.0, 40.0),
    ("ship2", -500.0, 6_000.0, 120.0, 30.0, 400.0, 250.0),
    ("ship3", 3_200.0, 1_300.0, 0.0, 10.0, None, 25.0),
    ("ship4", -1_500.0, 7_000.0, 0.0, 12.0, None, 60.0),
    ("ship5", -600.0, 700.0, 90.0, 6.0, None, 15.0),
]
HARBOUR_DURATION_S = 200.0


def _harbour(name: str, clutter_count: int) -> Scenario:
    targets = []
    for ship, x, y, heading, knots, radius, length in HARBOUR_SHIPS:
        speed = knots * KNOT_M_S
        turn = None if radius is None else math.degrees(speed / radius)  # deg/s, right turn
        targets.append(Target(name=ship, x_m=x, y_m=y, heading_deg=heading, speed_m_s=speed, length_m=length,
                              segments=[Segment(duration_s=HARBOUR_DURATION_S, turn_rate_deg_s=turn)]))
    sensors = tuple(s.model_copy(update={"clutter": s.clutter.model_copy(update={"count": clutter_count})})
                    for s in HARBOUR_RADARS)
    return Scenario(name=name, duration_s=HARBOUR_DURATION_S, targets=targets, sensors=sensors, seed=402,
                    process_noise=ProcessNoise(sigma_accel=0.05),
                    description=f"the harbour of Lima (2022): two radars with 90-degree sectors, five ships (two "
                                f"circling), ship 2 hiding ship 3 from radar 2; T = 1 s, {clutter_count} clutter "
                                "per sweep")


#: (name, x0 m, y0 m, heading deg, speed kn, turn rate deg/s or None): ten ships of an approach, two turning
AIS_SHIPS: list[tuple[str, float, float, float, float, float | None]] = [
    ("inbound1", -6_000.0, 4_000.0, 110.0, 12.0, None),
    ("inbound2", -5_000.0, -3_000.0, 60.0, 10.0, None),
    ("outbound1", 2_000.0, 1_000.0, 300.0, 14.0, None),
    ("outbound2", 3_000.0, -2_000.0, 250.0, 8.0, None),
    ("ferry", -1_000.0, -5_000.0, 0.0, 15.0, None),
    ("pilot", 1_000.0, 3_000.0, 180.0, 6.0, 0.4),
    ("tug", -2_000.0, 2_000.0, 90.0, 5.0, -0.3),
    ("anchored", 4_000.0, 4_000.0, 45.0, 1.0, None),
    ("fisher", 5_000.0, -4_000.0, 330.0, 7.0, None),
    ("yacht", -4_000.0, 0.0, 135.0, 9.0, None),
]
#: the AIS stream: position fixes with 10 m noise per axis, PD 0.95 per (window, ship), a Poisson mean of one
#: false report per 10 s window; no range limit inside 30 km
AIS_STREAM = Sensor(name="ais", kind="position", reports=True, scan_period_s=10.0, sigma_position_m=10.0,
                    min_range_m=0.0, max_range_m=30_000.0, pd=0.95, clutter=Clutter(count=1, count_law="poisson"))
AIS_DURATION_S = 600.0


def _ais_harbour() -> Scenario:
    targets = [Target(name=ship, x_m=x, y_m=y, heading_deg=heading, speed_m_s=knots * KNOT_M_S,
                      segments=[Segment(duration_s=AIS_DURATION_S, turn_rate_deg_s=turn)])
               for ship, x, y, heading, knots, turn in AIS_SHIPS]
    return Scenario(name="ais-harbour", duration_s=AIS_DURATION_S, targets=targets, sensors=(AIS_STREAM,), seed=503,
                    process_noise=ProcessNoise(sigma_accel=0.05),
                    description="ten ships (two turning) seen by AIS: each position report (10 m noise, PD 0.95) at "
                                "its own time, grouped in 10 s windows; 1 false report per window on average")


def _build() -> dict[str, Scenario]:
    presets = {s.name: s for s in (_training(i) for i in range(1, len(TRAINING_SCENARIOS) + 1))}
    presets.update({n: _trajectory(n) for n in VALIDATION_TRAJECTORIES})
    presets.update({n: _validation(n) for n in VALIDATION_SCENARIOS})
    presets["two-radars"] = _two_radars()
    presets["harbour"] = _harbour("harbour", 2)
    presets["harbour-dense"] = _harbour("harbour-dense", 50)
    presets["ais-harbour"] = _ais_harbour()
    return presets


PRESETS: dict[str, Scenario] = _build()

GROUPS: dict[str, list[str]] = {
    "train": [f"train{i:02d}" for i in range(1, len(TRAINING_SCENARIOS) + 1)],
    "trajectories": list(VALIDATION_TRAJECTORIES),
    "validation": list(VALIDATION_SCENARIOS),
    "multisensor": ["two-radars", "harbour", "harbour-dense"],
}
GROUP_DESCRIPTIONS = {
    "train": "the 17 training scenarios (one target each) that build the neural training set",
    "trajectories": "validation trajectories T1-T7, each alone",
    "validation": "multi-target validation scenarios S1-S6",
    "multisensor": "scenes with several sensors: two-radars and the harbour of Lima 2022 (2 or 50 clutter per sweep)",
}


def preset(name: str) -> Scenario:
    """The preset scenario ``name``; ConfigError listing the choices if unknown."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ConfigError(
            f"unknown preset {name!r}; choose one of {', '.join(PRESETS)} "
            f"or a group ({', '.join(GROUPS)})"
        ) from None


def resolve(name: str) -> list[Scenario]:
    """A preset or a group name -> its scenarios."""
    if name in GROUPS:
        return [PRESETS[n] for n in GROUPS[name]]
    return [preset(name)]
