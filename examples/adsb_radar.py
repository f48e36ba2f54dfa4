"""Recorded airliner positions (ADS-B, OpenSky Network states) seen by a simulated en-route radar.

    python examples/adsb_radar.py OpenSky_Plane_States.csv adsb --clutter 0 --seed 0
    nnda import-detections adsb/detections.csv --truth adsb/truth.csv --sensor scan_period_s=10 \\
        --sensor sigma_range_m=50 --sensor sigma_azimuth_mrad=1.5 --sensor min_range_m=5000 \\
        --sensor max_range_m=250000 --sensor pd=0.9 --out data/adsb

The input is a CSV of OpenSky state vectors with the columns ``time`` (s, the sweep times),
``icao24``, ``lat``, ``lon`` (deg), ``lastposupdate`` (s, when the position was reported) and
``onground``, as the file that Stone Soup's documentation demonstrates with
(``docs/demos/OpenSky_Plane_States.csv`` in its repository: 80 aircraft over England, 20 minutes of
2021-07-12). A state repeats an aircraft's last reported position until the next report comes (about
one state in nine here), so the truth is each aircraft's own reports, placed on a local east-north plane
about the radar (``--lat``, ``--lon``; nnda.data.geodesy) and interpolated linearly at the sweep times
that lie within 30 s reports of it. The radar at the origin sees each aircraft between 5 km and
``--range-km`` with probability ``--pd`` per sweep, its range and azimuth with Gaussian noise (``--sigma-range``
m, ``--sigma-azimuth`` mrad), and ``--clutter`` false plots a sweep spread evenly over its coverage.

Writes ``detections.csv`` (time s, range m, azimuth rad, target_id: the ICAO address, empty for clutter) and
``truth.csv`` (time, target_id, x, y m, vx, vy m/s) into the output directory; the times start at one sweep
period before the first sweep. Every draw comes from ``--seed``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from nnda.data.geodesy import GeodeticOrigin

#: the longest gap (s) between an aircraft's reports across which its position is interpolated
MAX_GAP_S = 30.0


def reports(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The sweep times (S,) and the airborne position reports: ICAO address, report time (s), lat, lon (deg)."""
    table = pacsv.read_csv(path, convert_options=pacsv.ConvertOptions(column_types={"icao24": pa.string()}))
    sweeps = np.unique(table["time"].to_numpy())
    airborne = pc.and_(pc.invert(pc.fill_null(table["onground"], False)),
                       pc.and_(pc.is_valid(table["lat"]), pc.is_valid(table["lastposupdate"])))
    t = table.filter(airborne)
    return (sweeps, t["icao24"].to_numpy(zero_copy_only=False).astype(str), t["lastposupdate"].to_numpy(),
            t["lat"].to_numpy(), t["lon"].to_numpy())


def truth_at_sweeps(sweeps, icao, when, x, y) -> dict[str, np.ndarray]:
    """Each aircraft's distinct reports interpolated at the sweeps within them (gaps of at most `MAX_GAP_S`)."""
    rows = []
    for name in np.unique(icao):
        mine = icao == name
        t, first = np.unique(when[mine], return_index=True)
        if t.size < 2:
            continue
        px, py = x[mine][first], y[mine][first]
        at = sweeps[(sweeps >= t[0]) & (sweeps <= t[-1])]
        k = np.clip(np.searchsorted(t, at), 1, t.size - 1)
        gap = t[k] - t[k - 1]
        w = (at - t[k - 1]) / gap
        keep = gap <= MAX_GAP_S
        vx, vy = (px[k] - px[k - 1]) / gap, (py[k] - py[k - 1]) / gap
        rows.append((at, np.full(at.size, name), px[k - 1] + w * (px[k] - px[k - 1]),
                     py[k - 1] + w * (py[k] - py[k - 1]), vx, vy, keep))
    at, names, tx, ty, vx, vy, keep = (np.concatenate(c) for c in zip(*rows))
    order = np.lexsort((names[keep], at[keep]))
    return {"time": at[keep][order], "target_id": names[keep][order], "x": tx[keep][order], "y": ty[keep][order],
            "vx": vx[keep][order], "vy": vy[keep][order]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("states", help="OpenSky state vectors (CSV)")
    parser.add_argument("out", help="directory for detections.csv and truth.csv")
    parser.add_argument("--lat", type=float, default=52.5, help="radar latitude, deg")
    parser.add_argument("--lon", type=float, default=-1.5, help="radar longitude, deg")
    parser.add_argument("--range-km", type=float, default=250.0)
    parser.add_argument("--pd", type=float, default=0.9)
    parser.add_argument("--sigma-range", type=float, default=50.0, help="m")
    parser.add_argument("--sigma-azimuth", type=float, default=1.5, help="mrad")
    parser.add_argument("--clutter", type=int, default=0, help="false plots a sweep")
    parser.add_argument("--seed", type=int, default=0)
    a = parser.parse_args()
    rng = np.random.default_rng(a.seed)
    sweeps, icao, when, lat, lon = reports(a.states)
    x, y, _ = GeodeticOrigin(a.lat, a.lon).to_local(lat, lon)
    truth = truth_at_sweeps(sweeps, icao, when, x, y)
    r = np.hypot(truth["x"], truth["y"])
    truth = {k: v[(r > 5_000.0) & (r < a.range_km * 1e3)] for k, v in truth.items()}
    start = sweeps[0] - (sweeps[1] - sweeps[0])
    seen = rng.random(truth["time"].size) < a.pd
    rng_m = np.hypot(truth["x"], truth["y"])[seen] + rng.normal(0.0, a.sigma_range, seen.sum())
    az = (np.arctan2(truth["x"], truth["y"])[seen] + rng.normal(0.0, a.sigma_azimuth * 1e-3, seen.sum())) % (2 * np.pi)
    t, ids = truth["time"][seen] - start, truth["target_id"][seen].astype(object)
    n = a.clutter * sweeps.size
    if n:
        rng_m = np.concatenate([rng_m, np.sqrt(rng.uniform(5e3**2, (a.range_km * 1e3) ** 2, n))])
        az = np.concatenate([az, rng.uniform(0.0, 2 * np.pi, n)])
        t = np.concatenate([t, np.repeat(sweeps - start, a.clutter)])
        ids = np.concatenate([ids, np.full(n, None, object)])
    order = np.lexsort((az, t))
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    pacsv.write_csv(pa.table({"time": t[order], "range": rng_m[order], "azimuth": az[order],
                              "target_id": pa.array(list(ids[order]), pa.string())}), out / "detections.csv")
    pacsv.write_csv(pa.table({**truth, "time": truth["time"] - start}), out / "truth.csv")
    print(f"{np.unique(truth['target_id']).size} aircraft over {sweeps.size} sweeps: {seen.sum()} plots of "
          f"aircraft and {n} of clutter in {out}")


if __name__ == "__main__":
    main()
