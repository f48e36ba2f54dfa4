"""The walker scenes of Tests 2-4 of Frencl (2014), Secs. 6.2-6.4, ready to generate.

The thesis's maps survive only as figure captions, so every map here is our
drawing of what the text says (sizes, kinds of region, how many generators,
waypoints and sinks); positions of boxes and waypoints are ours:

* ``walk-test2``: the 50 x 50 m scene of Test 2: a lawn with two buildings,
  a sidewalk, a gravel patch, two gates, two doors; one walker of
  a = [1.5, 0.5, 1.0], leaf lambda 7, 45 s, the same trajectory in every
  Monte Carlo run (``fixed_truth``, as the thesis's 300 runs);
* ``walk-stress``: the same map, 100 s, 10 walkers at time 0, 6 spawned in the
  first 50 s and spontaneous births (0.05 per s), person set A =
  {[1.5, 0.5, 1.0], [2.0, 1.0, 0.75]};
* ``walk-test3``: the 48 x 48 m "+" of Fig. 5.1: four corner obstacle blocks
  leaving 12 m-wide arms about x = 24 and y = 24, a south gate, one waypoint
  at the centre, sinks at the ends of the north, east and west arms; one
  walker, 45 s, fixed truth (the thesis's Test-3 parameters were lost);
* ``walk-test3-stress``: the "+" map with the stress scene's walkers;
* ``walk-test4``: the 100 x 50 m corridor of Test 4, 9 m wide about y = 25
  (0.5 m cells), a gate at its west end and a sink at its east end; one
  walker, leaf lambda 3, 60 s, a new trajectory in every run.

``PEDESTRIAN_SCENES`` maps each name to its `WalkerScene`; `generate_walkers`
(or ``nnda generate --preset walk-test2``) turns one into a dataset.
"""

from __future__ import annotations

from nnda.data.pedestrian.terrain import TerrainMap
from nnda.data.pedestrian.walkers import PersonType, Profile, WalkerScene

#: the thesis's person vector of its single-walker runs and its person set A (its Sec. 6.2)
ONE_PERSON = [PersonType(mean_speed_m_s=1.5, speed_std_m_s=0.5, continuity=1.0)]
PERSON_SET_A = [PersonType(mean_speed_m_s=1.5, speed_std_m_s=0.5, continuity=1.0),
                PersonType(mean_speed_m_s=2.0, speed_std_m_s=1.0, continuity=0.75)]
#: the stress scenes' births: 10 at time 0, 6 spawned in the first 50 s, spontaneous ones (our rate)
STRESS = {"initial": 10, "spawned": 6, "spawn_until_s": 50.0, "birth_rate_per_s": 0.05, "duration_s": 100.0}

LAWN = TerrainMap.model_validate({
    "name": "lawn-50", "width_m": 50.0, "height_m": 50.0,
    "regions": [
        {"kind": "easy", "box": [0.0, 22.0, 50.0, 28.0]},          # sidewalk, west to east
        {"kind": "difficult", "box": [20.0, 34.0, 28.0, 44.0]},    # gravel
        {"kind": "obstacle", "box": [30.0, 32.0, 40.0, 45.0]},     # building
        {"kind": "obstacle", "box": [10.0, 5.0, 20.0, 15.0]},      # building
        {"kind": "generator", "name": "west-gate", "box": [0.0, 22.0, 2.0, 28.0], "accessible": ["crossing"]},
        {"kind": "generator", "name": "south-gate", "box": [42.0, 0.0, 48.0, 2.0],
         "accessible": ["crossing", "east-door"]},
        {"kind": "sink", "name": "east-door", "box": [48.0, 22.0, 50.0, 28.0]},
        {"kind": "sink", "name": "north-exit", "box": [8.0, 48.0, 16.0, 50.0]},
    ],
    "waypoints": [
        {"name": "crossing", "x_m": 25.0, "y_m": 25.0, "radius_m": 3.0, "accessible": ["east-door", "north-turn"]},
        {"name": "north-turn", "x_m": 12.0, "y_m": 38.0, "radius_m": 3.0, "accessible": ["north-exit"]},
    ],
})

PLUS = TerrainMap.model_validate({
    "name": "plus-48", "width_m": 48.0, "height_m": 48.0,
    "regions": [
        {"kind": "obstacle", "box": [0.0, 0.0, 18.0, 18.0]}, {"kind": "obstacle", "box": [30.0, 0.0, 48.0, 18.0]},
        {"kind": "obstacle", "box": [0.0, 30.0, 18.0, 48.0]}, {"kind": "obstacle", "box": [30.0, 30.0, 48.0, 48.0]},
        {"kind": "generator", "name": "south-gate", "box": [18.0, 0.0, 30.0, 2.0], "accessible": ["centre"]},
        {"kind": "sink", "name": "north-exit", "box": [18.0, 46.0, 30.0, 48.0]},
        {"kind": "sink", "name": "east-exit", "box": [46.0, 18.0, 48.0, 30.0]},
        {"kind": "sink", "name": "west-exit", "box": [0.0, 18.0, 2.0, 30.0]},
    ],
    "waypoints": [{"name": "centre", "x_m": 24.0, "y_m": 24.0, "radius_m": 3.0,
                   "accessible": ["north-exit", "east-exit", "west-exit"]}],
})

CORRIDOR = TerrainMap.model_validate({
    "name": "corridor-100", "width_m": 100.0, "height_m": 50.0, "cell_m": 0.5,
    "regions": [
        {"kind": "obstacle", "box": [0.0, 0.0, 100.0, 20.5]}, {"kind": "obstacle", "box": [0.0, 29.5, 100.0, 50.0]},
        {"kind": "generator", "name": "west-end", "box": [0.0, 20.5, 2.0, 29.5], "accessible": ["east-end"]},
        {"kind": "sink", "name": "east-end", "box": [98.0, 20.5, 100.0, 29.5]},
    ],
})

PEDESTRIAN_SCENES: dict[str, WalkerScene] = {s.name: s for s in (
    WalkerScene(name="walk-test2", map=LAWN, duration_s=45.0, people=ONE_PERSON, fixed_truth=True, seed=2,
                description="Frencl (2014) Test 2: one walker on the 50 x 50 m lawn, leaf 7, 45 s, fixed truth"),
    WalkerScene(name="walk-stress", map=LAWN, people=PERSON_SET_A, seed=20, **STRESS,
                description="Frencl (2014) stress scene: 10 initial, 6 spawned and spontaneous walkers, 100 s"),
    WalkerScene(name="walk-test3", map=PLUS, duration_s=45.0, people=ONE_PERSON, fixed_truth=True, seed=3,
                description="Frencl (2014) Test 3: one walker on the 48 x 48 m '+' map of Fig. 5.1, 45 s, fixed truth"),
    WalkerScene(name="walk-test3-stress", map=PLUS, people=PERSON_SET_A, seed=30, **STRESS,
                description="Frencl (2014) Test 3 stress scene on the '+' map: 10 initial, 6 spawned, spontaneous"),
    WalkerScene(name="walk-test4", map=CORRIDOR, duration_s=60.0, people=ONE_PERSON, seed=4,
                profile=Profile(kind="leaf", parameter=3.0),
                description="Frencl (2014) Test 4: one walker in the 9 m-wide corridor, leaf 3, 60 s"),
)}
