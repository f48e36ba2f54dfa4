"""Every preset against the numbers of Vargas Avila (2015)'s scenarios (Chapter 5 and Appendix G)."""

from __future__ import annotations

import pytest

from nnda.data.presets import GROUPS, PRESETS, preset, resolve
from nnda.errors import ConfigError

G8 = [7, 8, 15, 16, 17, 24, 25, 30, 36, 37, 38, 42, 43, 47, 51, 52, 53]
T51 = [7, 8, 15, 16, 17, 24, 25, 30, 36, 37, 38]
T52 = [7, 8, 15, 16, 17, 24, 25, 30, 36, 37, 38, 42, 43, 47, 51, 52, 53, 100, 101, 102, 115]

# the training scenarios: (duration s, scans, gap scans, initial speed m/s, segment (duration, a_t, a_n) list)
TRAINING = {
    1: (76, 38, [], 99, [(50, 0, 0), (26, 5, 0)]),
    2: (76, 38, T51, 99, [(50, 0, 0), (26, 5, 0)]),
    3: (260, 130, T52, 99, [(80, 0, 0), (100, 0, 5), (80, 0, 0)]),
    4: (260, 130, T52, 99, [(80, 0, 0), (100, 0, 5), (80, 0, 0)]),
    5: (100, 50, T51 + [42, 43, 47], 85, [(100, 0, 3)]),
    6: (162, 81, G8, 150, [(50, 0, 0), (36, 0, 13), (36, 0, -13), (40, 0, 6)]),
    7: (162, 81, G8, 150, [(50, 0, 0), (36, 0, 13), (36, 0, -13), (40, 0, 6)]),
    8: (30, 15, [], 85, [(30, 3, 5)]),
    9: (30, 15, [7, 8], 85, [(30, 3, 5)]),
    10: (60, 30, [7, 8, 15, 16, 17, 24, 25], 85, [(30, 4, 0), (30, -4, 0)]),
    11: (120, 60, G8, 85, [(30, 4, 0), (50, 0, 10.33), (40, 0, 12.88)]),
    12: (140, 70, G8, 141.4, [(40, 0, 0), (50, 0, -10), (50, 0, -5)]),
    13: (140, 70, G8, 141.4, [(40, 0, 0), (50, 0, -10), (50, 0, -5)]),
    14: (200, 100, G8 + [63, 64, 65, 71, 72, 85], 108.17, [(200, 0, 3.48)]),
    15: (120, 60, G8, 127.28, [(120, 0, -6.6)]),
    16: (150, 75, G8, 113.14, [(100, 0, 0), (50, 0, -5)]),
    17: (120, 60, G8, 160, [(40, 0, 11.2), (40, 0, -11.2), (40, 0, 13)]),
}

# Vargas Avila (2015), Tables 5.12 / 5.13 (targets in the order of its scenario table)
VALIDATION_GAPS = {
    "S1": {"T1": [], "T2.1": [], "T2.2": [], "T3a": []},
    "S2": {"T4": [], "T5": [], "T6": [], "T7": []},
    "S3": {"T4": [], "T5": [24, 25, 40, 41, 42], "T6": [15, 25, 26, 27, 85, 86], "T7": [8, 50, 51]},
    "S4": {"T1": [], "T3a": [], "T3b": [], "T5": []},
    "S5": {"T1": [10, 20, 21, 47, 58, 59, 60], "T3a": [11, 12, 24], "T3b": [9, 16, 17], "T5": []},
    "S6": {"T1": [], "T2": [], "T3a": [], "T3b": [], "T3c": [], "T5": []},
}
TRAJECTORY_DURATIONS = {"T1": 170, "T2": 150, "T3": 60, "T4": 150, "T5": 115, "T6": 180, "T7": 115}


def _sections(target):
    return [(s.duration_s, s.tangential_accel, s.normal_accel or 0.0) for s in target.segments]


@pytest.mark.parametrize("i", sorted(TRAINING))
def test_training_preset_matches_spec(i):
    duration, scans, gaps, speed, sections = TRAINING[i]
    sc = PRESETS[f"train{i:02d}"]
    assert sc.duration_s == duration and sc.n_scans == scans
    assert len(sc.targets) == 1
    target = sc.targets[0]
    assert target.missed_scans == gaps
    assert target.speed_m_s == speed
    assert _sections(target) == sections
    assert sc.clutter.law == "square" and sc.clutter.count == 100 and sc.clutter.side_m == 16_600


def test_training_totals_match_spec():
    train = resolve("train")
    assert len(train) == 17
    assert sum(s.n_scans for s in train) == 1103
    assert sum(len(s.targets[0].missed_scans) for s in train) == 235


@pytest.mark.parametrize("name", sorted(VALIDATION_GAPS))
def test_validation_preset_matches_spec(name):
    sc = PRESETS[name]
    assert sc.duration_s == 200 and sc.n_scans == 100
    assert {t.name: t.missed_scans for t in sc.targets} == VALIDATION_GAPS[name]
    for t in sc.targets:
        assert t.duration_s == TRAJECTORY_DURATIONS[t.name[:2]]
    assert sc.clutter.count == 100


def test_s3_and_s5_repeat_s2_and_s4_placements():
    for a, b in (("S2", "S3"), ("S4", "S5")):
        strip = [t.model_copy(update={"missed_scans": []}) for t in PRESETS[b].targets]
        assert strip == PRESETS[a].targets
    assert sum(len(t.missed_scans) for t in PRESETS["S3"].targets) == 14
    assert sum(len(t.missed_scans) for t in PRESETS["S5"].targets) == 13


def test_t5_and_t7_are_mirror_images():
    t5, t7 = PRESETS["T5"].targets[0], PRESETS["T7"].targets[0]
    assert [(d, a, -n) for d, a, n in _sections(t5)] == _sections(t7)


def test_groups_and_unknown_preset():
    assert set(GROUPS) == {"train", "trajectories", "validation", "multisensor"}
    assert [s.name for s in resolve("validation")] == ["S1", "S2", "S3", "S4", "S5", "S6"]
    with pytest.raises(ConfigError, match="unknown preset 'S9'"):
        preset("S9")
