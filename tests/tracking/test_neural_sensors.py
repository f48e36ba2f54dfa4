"""The neural tracker on several sensors and on position fixes: each sensor's scans update the same tracks, and
the sector gate reads its azimuths from the sweeping sensor's position."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nnda.data.dataset import Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Scenario
from nnda.data.sensor import cart_to_polar_at
from nnda.errors import ConfigError, TrackingError
from nnda.models.features import sector
from nnda.study.metrics import run_metrics
from nnda.tracking.neural import life5
from nnda.tracking.registry import make_tracker

TWO = PRESETS["two-radars"]


def _metrics(scenario: Scenario, seed: int, config: dict):
    ds = generate(scenario, seed)
    tracker = make_tracker("nn", ds.scenario.sensors, config)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # bound warnings of the life cycle: counted, not asserted here
        return run_metrics(ds, [tracker.step(scan) for scan in ds.scans()])


@pytest.mark.parametrize(("model", "seed"), [("model_file", 5), ("ext_model_file", 3)])
def test_nn_on_two_radars_tracks_better_than_either_alone(model, seed, request):
    """With the settings of `life5` (IMM gates around the network's picks) both radars together beat either
    alone, as for gnn and mht (GOSPA per scan; measured both / best alone: 0.66 for the kinematic model at seed
    5, 0.76 for the extended one at seed 3)."""
    config = {"model": str(request.getfixturevalue(model)), **life5()}
    both = float(np.mean(_metrics(TWO, seed, config).gospa))
    alone = [float(np.mean(_metrics(TWO.model_copy(update={"sensors": (s,)}), seed, config).gospa))
             for s in TWO.sensors]
    assert both < 0.85 * min(alone), (both, alone)


def _fixes(preset: str, sigma_m: float = 30.0) -> Scenario:
    """``preset`` with its radar replaced by a sensor of position fixes at the same place."""
    radar = PRESETS[preset].sensors[0]
    fixes = radar.model_copy(update={"kind": "position", "name": "fixes", "sigma_position_m": sigma_m})
    return PRESETS[preset].model_copy(update={"sensors": (fixes,)})


def test_nn_confirms_the_targets_of_position_fixes(model_file):
    """S1 seen as position fixes (30 m per axis) is tracked as well as by its radar (measured: hit rate 95.4 %,
    MOTA 0.868, no false track; the radar: 95.1 %, 0.868). With the fixes' y read as azimuths, as the radar's
    second measurement column, the sector gate keeps almost no target pair (hit rate 7.7 %)."""
    m = _metrics(_fixes("S1"), 0, {"model": str(model_file)})
    assert m.hit_rate >= 94.0 and m.mota >= 0.85 and m.false_tracks == 0, (m.hit_rate, m.mota, m.false_tracks)


def test_the_sector_gate_reads_both_azimuths_from_the_sweeping_radar(model_file):
    """A target north of the two radars' midpoint lies in sector 1 from the west radar and sector 14 from the east
    one: a track started by the west radar is a candidate for the east radar's contact only if its last contact's
    sector is taken from the east radar too."""
    west, east = TWO.sensors
    tracker = make_tracker("nn", TWO.sensors, {"model": str(model_file)})
    pairs = []
    tracker.harvest = lambda scan, track_id, contact, features: pairs.append((scan, track_id.tolist(),
                                                                              contact.tolist()))

    def at(sensor, time: float) -> np.ndarray:  # the target flies north at 100 m/s from (0, 15 km)
        return np.column_stack(cart_to_polar_at(sensor.position, np.array([0.0]), np.array([15_000.0 + 100 * time])))

    for index, (s, time) in enumerate([(0, 2.0), (0, 4.0), (1, 5.0)], start=1):
        out = tracker.step(Scan(index, time, at(TWO.sensors[s], time), sensor=s))
    assert [int(sector(at(r, 4.0)[0, 1])) for r in (west, east)] == [1, 14]
    assert pairs == [(3, [0], [0])]
    assert out.contact[out.track_id == 0].tolist() == [0]  # the network took it (ΔV = Δα = 0)


def test_a_model_of_imm_features_is_refused_with_a_position_sensor(ext_model_file):
    with pytest.raises(ConfigError, match=r"field 'model': .* trained on feature set 'imm-innovation-9', whose IMM "
                                          r"columns are residuals in a polar radar's \[range, azimuth\], but "
                                          r"sensor\(s\) fixes give position fixes; use a model of feature set "
                                          r"'kinematic-3'"):
        make_tracker("nn", _fixes("S1").sensors, {"model": str(ext_model_file)})
    assert make_tracker("nn", TWO.sensors, {"model": str(ext_model_file)})  # several radars: polar residuals


def test_a_scan_from_a_sensor_the_tracker_was_not_built_for_is_refused(model_file):
    tracker = make_tracker("nn", TWO.sensors, {"model": str(model_file)})
    tracker.step(Scan(1, 1.0, np.empty((0, 2)), sensor=1))
    with pytest.raises(TrackingError, match=r"nn: scan 2 comes from sensor 2, but this tracker was built for 2 "
                                            r"sensor\(s\) \(west, east\)"):
        tracker.step(Scan(2, 2.0, np.array([[10_000.0, 0.5]]), sensor=2))


def test_two_radars_sweeping_at_one_instant_are_tracked(model_file):
    """The second radar sweeps at the first one's instants: a track that takes both radars' contacts of one instant
    (through the IMM's gates) has no last speed, so the network scores none of its pairs until a later contact,
    and the tracking is as good as with the sweeps 1 s apart (measured: GOSPA 236.0 m both ways, seed 3)."""
    def gospa(offset_s: float) -> float:
        east = TWO.sensors[1].model_copy(update={"scan_offset_s": offset_s})
        sc = TWO.model_copy(update={"sensors": (TWO.sensors[0], east)})
        return float(np.mean(_metrics(sc, 3, {"model": str(model_file), **life5()}).gospa))

    at_once, apart = gospa(0.0), gospa(1.0)
    assert at_once < 1.25 * apart, (at_once, apart)
