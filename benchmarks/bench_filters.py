"""IMM speed: microseconds per predict + update cycle for K = 1, 10, 1000 tracks.

nnda's batched IMM (Vargas Avila (2015)'s CV + CT models, polar EKF) is timed on K
tracks at once. The reference, timed in the same process on the same
measurements, is filterpy's IMMEstimator running the same IMM one track at
a time: CV written in five states with omega forced to 0 plus the CT EKF,
through the glue in tests/filters/reference_filters.py (the tests check that
both give the same numbers to 1e-9). filterpy's cheapest two-model IMM (two
linear CV Kalman filters on position fixes) is printed as well, as the
lower bound of what an IMM cycle costs there.

Each figure is the best of REPEATS timings of SCANS cycles. Usage:
python benchmarks/bench_filters.py [SCANS]
"""

from __future__ import annotations

import sys
import timeit
from pathlib import Path

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "filters"))
import reference_filters as ref  # noqa: E402

from nnda.data.scenario import Sensor  # noqa: E402
from nnda.data.sensor import measure  # noqa: E402
from nnda.filters.imm import IMM  # noqa: E402

REPEATS = 5
DT = 2.0
FILTERPY_TRACKS = 5


def measurements(k: int, scans: int, seed: int = 0) -> np.ndarray:
    """Polar measurements (k, scans + 2, 2) of k straight tracks 7-23 km from the radar."""
    rng = np.random.default_rng(seed)
    r0 = rng.uniform(7e3, 23e3, k)
    a0 = rng.uniform(0, 2 * np.pi, k)
    heading = rng.uniform(0, 2 * np.pi, k)
    speed = rng.uniform(70, 200, k)
    t = DT * np.arange(scans + 2)
    x = (r0 * np.sin(a0))[:, None] + (speed * np.sin(heading))[:, None] * t
    y = (r0 * np.cos(a0))[:, None] + (speed * np.cos(heading))[:, None] * t
    r, az = measure(Sensor(), x, y, rng)
    return np.stack([r, az], axis=-1)


def best(fn) -> float:
    """Best wall time (s) of REPEATS calls."""
    return min(timeit.repeat(fn, number=1, repeat=REPEATS))


def nnda_cycle_us(k: int, scans: int) -> float:
    """Microseconds per predict + update of all k tracks."""
    imm = IMM()
    Z = measurements(k, scans)
    dt = np.full(k, DT)

    def run() -> None:
        state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, DT)
        for s in range(2, scans + 2):
            state = imm.update(imm.predict(state, dt), Z[:, s])

    return best(run) / scans * 1e6


def filterpy_spec_us(scans: int) -> float:
    """Microseconds per predict + update of one track, filterpy IMMEstimator with the same IMM."""
    Z = measurements(FILTERPY_TRACKS, scans)

    def run() -> None:
        for z in Z:
            x0, P0 = ref.two_point(z[0], z[1], DT)
            x5, P5 = np.append(x0, 0.0), np.pad(P0, ((0, 1), (0, 1)))
            P5_ct = P5.copy()
            P5_ct[4, 4] = ref.P_OMEGA
            filters = [ref.PolarEKF("cv5", x5, P5, 3.5), ref.PolarEKF("ct", x5, P5_ct, 5.0)]
            imm = IMMEstimator(filters, [0.5, 0.5], ref.TPM)
            for s in range(2, scans + 2):
                imm.predict()
                imm.update(z[s])

    return best(run) / (scans * FILTERPY_TRACKS) * 1e6


def filterpy_linear_us(scans: int) -> float:
    """Microseconds per cycle of filterpy's cheapest two-model IMM: two linear CV filters on position fixes."""
    Z = measurements(1, scans)[0]
    xy = np.column_stack([Z[:, 0] * np.sin(Z[:, 1]), Z[:, 0] * np.cos(Z[:, 1])])

    def make(sigma_q: float) -> KalmanFilter:
        kf = KalmanFilter(dim_x=4, dim_z=2)
        kf.F, kf.Q = ref.cv_F(DT), ref.cv_Q(DT, sigma_q)
        kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
        kf.R = np.eye(2) * 900.0
        kf.x = np.array([xy[1, 0], 0.0, xy[1, 1], 0.0])
        kf.P = np.diag([900.0, 1e4, 900.0, 1e4])
        return kf

    def run() -> None:
        imm = IMMEstimator([make(3.5), make(0.5)], [0.5, 0.5], ref.TPM)
        for s in range(2, scans + 2):
            imm.predict()
            imm.update(xy[s])

    return best(run) / scans * 1e6


def main(scans: int = 100) -> None:
    print(f"IMM predict + update, CV + CT with polar EKF; best of {REPEATS} x {scans} scans")
    fp = filterpy_spec_us(scans)
    fp_lin = filterpy_linear_us(scans)
    print(f"filterpy IMMEstimator, same IMM (EKF glue), per track      {fp:9.1f} us per cycle")
    print(f"filterpy IMMEstimator, two linear CV filters, per track    {fp_lin:9.1f} us per cycle")
    print(f"{'K':>6s} {'us/cycle (all K)':>18s} {'us/track':>10s} "
          f"{'x filterpy (same IMM)':>22s} {'x filterpy (linear)':>20s}")
    for k in (1, 10, 1000):
        us = nnda_cycle_us(k, scans if k < 1000 else max(10, scans // 5))
        print(f"{k:>6d} {us:>18.1f} {us / k:>10.2f} {fp / (us / k):>21.1f}x {fp_lin / (us / k):>19.1f}x")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
