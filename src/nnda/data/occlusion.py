"""Occlusion: a ship hides the smaller ships behind it from a sensor (the harbour of Lima (2022), Ch. 4).

Each target with a length L (m, `Target.length_m`) spans the bearings
within atan(L / 2 / r) of its own as seen from a sensor at range r: a
broadside hull, the widest it can look. A target is hidden from the sensor
in a scan when a *nearer* and *longer* target spans its bearing (its centre
lies in that shadow). A target without a length is a point: it hides
nothing and a ship can hide it. Hidden targets are not detected by that
sensor in that scan (`nnda.data.generator`); the other sensors still see
them. The rule ignores the hidden ship's own extent, heights and the
radar horizon. Lima (2022) gives no ship dimensions and does not describe
the occlusion mechanism (it lives inside its MATLAB radar model), so this
rule and the lengths are ours.
"""

from __future__ import annotations

import numpy as np

from nnda.data.sensor import cart_to_polar_at, wrap_angle


def shadow_half_width(length_m: np.ndarray, range_m: np.ndarray) -> np.ndarray:
    """Half the bearing span (rad) of hulls of ``length_m`` at ``range_m`` (broadside): atan(L / 2 / r)."""
    return np.arctan2(0.5 * np.asarray(length_m, dtype=float), range_m)


def hidden(origin: tuple[float, float], scan: np.ndarray, x: np.ndarray, y: np.ndarray,
           length_m: np.ndarray) -> np.ndarray:
    """Which rows are hidden from a sensor at ``origin`` (m) by another row of the same scan.

    Rows (M,) are targets in scans: ``scan`` the scan index, ``x``, ``y``
    (m) the target's position and ``length_m`` its length (0: a point).
    Row i is hidden when a row j of the same scan is nearer (r_j < r_i),
    longer (L_j > L_i) and |bearing_i - bearing_j| < atan(L_j / 2 / r_j).
    Vectorised over scans: one (scans, K, K) comparison, K the most targets
    in a scan. Returns a boolean mask (M,).
    """
    scan = np.asarray(scan)
    out = np.zeros(scan.size, dtype=bool)
    if scan.size == 0 or not np.any(np.asarray(length_m) > 0):
        return out
    r, bearing = cart_to_polar_at(origin, x, y)
    scans, row_scan = np.unique(scan, return_inverse=True)
    order = np.argsort(row_scan, kind="stable")
    starts = np.searchsorted(row_scan[order], np.arange(scans.size))
    slot = np.empty(scan.size, dtype=np.int64)
    slot[order] = np.arange(scan.size) - starts[row_scan[order]]  # position of each row inside its scan
    K = int(slot.max()) + 1
    R = np.full((scans.size, K), np.inf)
    B = np.zeros((scans.size, K))
    L = np.zeros((scans.size, K))
    R[row_scan, slot], B[row_scan, slot], L[row_scan, slot] = r, bearing, length_m
    # [s, i, j]: row i of scan s hidden by row j of the same scan
    by = ((R[:, None, :] < R[:, :, None]) & (L[:, None, :] > L[:, :, None])
          & (np.abs(wrap_angle(B[:, :, None] - B[:, None, :])) < shadow_half_width(L, R)[:, None, :]))
    return by.any(axis=2)[row_scan, slot]
