"""The shipped examples run: examples/adsb_radar.py on a small file of OpenSky-format states, and the Solent AIS
recording (examples/data) with examples/ais.toml."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from nnda.data.detections_import import import_detections
from nnda.data.geodesy import GeodeticOrigin
from nnda.study.track import run_tracker

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "adsb_radar.py"


def _states(path: Path) -> None:
    """Three aircraft flying straight at 230 m/s for 3 minutes, a state every 10 s; each fourth state repeats the
    last reported position (its ``lastposupdate`` unchanged), as OpenSky's states do; a fourth aircraft on the
    ground."""
    origin = GeodeticOrigin(52.5, -1.5)
    rows = []
    for k, (x0, y0, heading) in enumerate([(-60e3, 20e3, 90.0), (30e3, -80e3, 10.0), (50e3, 60e3, 225.0)]):
        vx, vy = 230.0 * np.sin(np.radians(heading)), 230.0 * np.cos(np.radians(heading))
        reported = 0.0
        for step in range(19):
            t = 10.0 * step
            if step % 4 != 3:
                reported = t - 0.4
            lat, lon = origin.on_surface(np.array([x0 + vx * reported]), np.array([y0 + vy * reported]))
            rows.append((1_626_098_400 + t, f"a{k}", float(lat[0]), float(lon[0]), 1_626_098_400 + reported, False))
    rows.append((1_626_098_400.0, "g0", 52.45, -1.7, 1_626_098_399.0, True))
    time, icao, lat, lon, last, ground = zip(*rows)
    pacsv.write_csv(pa.table({"time": time, "icao24": icao, "lat": lat, "lon": lon, "lastposupdate": last,
                              "onground": ground}), path)


def test_adsb_radar_writes_plots_that_import_and_track(tmp_path):
    _states(tmp_path / "states.csv")
    done = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "states.csv"), str(tmp_path / "adsb"),
                           "--clutter", "5", "--seed", "1"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "3 aircraft over 19 sweeps" in done.stdout
    truth = pacsv.read_csv(tmp_path / "adsb" / "truth.csv")
    # the stale states are not the truth: each aircraft moves 2,300 m every sweep
    for name in ("a0", "a1", "a2"):
        mine = truth.filter(pa.compute.equal(truth["target_id"], name))
        step = np.hypot(np.diff(mine["x"].to_numpy()), np.diff(mine["y"].to_numpy()))
        assert np.allclose(step, 2_300.0, rtol=1e-3), step
    _, dataset = import_detections(tmp_path / "adsb" / "detections.csv", tmp_path / "data",
                                   truth=tmp_path / "adsb" / "truth.csv",
                                   sensors=[{"scan_period_s": 10.0, "sigma_range_m": 50.0, "sigma_azimuth_mrad": 1.5,
                                             "min_range_m": 5_000.0, "max_range_m": 250_000.0, "pd": 0.9}])
    assert len(dataset.scenario.targets) == 3
    run = run_tracker(dataset, "gnn", {"lifecycle": {"v_max": 300.0}})
    assert run.scores.values["hit_rate"] > 80.0 and run.scores.values["false_tracks"] == 0


AIS = Path(__file__).resolve().parents[1] / "examples" / "data" / "solent_ais.csv.gz"
AIS_CONFIG = Path(__file__).resolve().parents[1] / "examples" / "ais.toml"


def test_the_shipped_ais_recording_imports_as_it_is_and_gnn_keeps_one_track_a_ship():
    """The Solent recording (asynchronous reports at their own millisecond times) imports with no rounding; gnn
    with examples/ais.toml never holds more confirmed tracks than 1.1 times the ships present (a report in the
    last report_gap_s), and has no false track."""
    import tomllib

    from nnda.data.detections_import import read_detections
    from nnda.tracking.output import CONFIRMED

    data = read_detections(AIS, sensors=[{"kind": "position", "reports": True, "scan_period_s": 10.0,
                                          "sigma_position_m": 10.0}],
                           columns={"time": "Time", "target_id": "MMSI", "lat": "Latitude_degrees",
                                    "lon": "Longitude_degrees"},
                           region="lat:50.5,50.9,lon:-1.45,-0.7", truth_from_labels=200.0)
    d = data.detections
    assert d.time.size == 18_622 and np.unique(d.target_id).size == 91
    params = tomllib.loads(AIS_CONFIG.read_text())
    gap = params["lifecycle"]["report_gap_s"]
    run = run_tracker(data, "gnn", params)
    for out in run.outputs:
        recent = (d.time > out.time - gap) & (d.time <= out.time)
        assert (out.status == CONFIRMED).sum() <= max(1.1 * np.unique(d.target_id[recent]).size, 1)
    assert run.scores.values["false_tracks"] == 0 and run.scores.values["mota"] > 0.4
