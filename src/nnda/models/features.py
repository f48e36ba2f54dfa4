"""Pair features of the neural association and candidate gating (spec §8.1, §8.2).

A *pair* joins a track, summarised by its last two contacts P1 (time t1)
and P2 (time t2), with a candidate contact C (time tc) of a later scan.
Its features, in this order:

* ``delta_speed`` ΔV (m/s): the speed needed to reach C from P2,
  |C - P2| / (tc - t2), minus the track's last speed |P2 - P1| / (t2 - t1);
* ``course_rate`` Δα (deg/s): the course change α = course(P2 -> C) -
  course(P1 -> P2), wrapped to (-180, 180] deg, divided by ΔT. A course is
  the bearing of a displacement, clockwise from north, so Δα > 0 is a turn
  to the right (starboard);
* ``delta_t`` ΔT (s): tc - t2, which grows across missed scans.

Δα stays in deg/s, the unit in which the spec defines the network input
(the z-score normaliser makes the unit immaterial to the network).

Gating keeps a pair only if C lies in the azimuth sector of P2 or in one of
its two neighbours (16 wedges of 22.5 deg clockwise from north, wrapping),
and if the speed needed to reach it lies within 30..400 m/s (bounds
included).

Everything works on flat arrays of pairs, so one call serves a whole scan:
a tracker gathers, per pair, its track's P1/P2 and its contact with index
arrays and calls `pair_features` once (`candidate_pairs` gives those
indices for many tracks and contacts at once).
"""

from __future__ import annotations

import numpy as np

from nnda.data.sensor import TWO_PI, wrap_angle
from nnda.errors import ModelError

#: Name and version of this feature definition; a model file records both and
#: the loader refuses a model trained on another definition.
FEATURE_SET = "kinematic-3"
FEATURE_VERSION = 1
FEATURE_NAMES = ("delta_speed_m_s", "course_rate_deg_s", "delta_t_s")

N_SECTORS = 16
MIN_SPEED_M_S = 30.0
MAX_SPEED_M_S = 400.0


def course(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """Bearing (rad, clockwise from north, in (-pi, pi]) of displacements (dx east, dy north) in m."""
    return np.arctan2(dx, dy)


def _positions(name: str, p: np.ndarray) -> np.ndarray:
    p = np.asarray(p, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ModelError(f"pair features: {name} must have shape (N, 2) [x, y] in m, got {p.shape}")
    return p


def _check_finite(name: str, a: np.ndarray) -> None:
    if not np.isfinite(a).all():
        bad = np.flatnonzero(~np.isfinite(a).reshape(len(a), -1).all(axis=1))[0]
        raise ModelError(f"pair features: {name} has a non-finite value at row {bad}")


def pair_features(
    p1: np.ndarray, t1: np.ndarray, p2: np.ndarray, t2: np.ndarray, c: np.ndarray, tc: np.ndarray,
) -> np.ndarray:
    """Features of N pairs, shape (N, 3): [ΔV m/s, Δα deg/s, ΔT s].

    ``p1``, ``p2``, ``c``: (N, 2) positions [x east, y north] in m of each
    pair's last-but-one track contact, last track contact and candidate;
    ``t1``, ``t2``, ``tc``: (N,) their times in s, with t1 < t2 < tc.
    Raises ModelError on wrong shapes, non-finite values or times out of order.
    """
    p1, p2, c = _positions("p1", p1), _positions("p2", p2), _positions("c", c)
    n = len(p1)
    t1, t2, tc = (np.broadcast_to(np.asarray(t, dtype=float), (n,)) for t in (t1, t2, tc))
    if len(p2) != n or len(c) != n:
        raise ModelError(f"pair features: p1, p2 and c differ in length ({n}, {len(p2)}, {len(c)})")
    for name, a in (("p1", p1), ("t1", t1), ("p2", p2), ("t2", t2), ("c", c), ("tc", tc)):
        _check_finite(name, a)
    before, gap = t2 - t1, tc - t2
    if np.any(before <= 0) or np.any(gap <= 0):
        bad = np.flatnonzero((before <= 0) | (gap <= 0))[0]
        raise ModelError(f"pair features: times must satisfy t1 < t2 < tc; row {bad} has "
                         f"t1={t1[bad]}, t2={t2[bad]}, tc={tc[bad]}")
    last = p2 - p1
    step = c - p2
    speed_now = np.hypot(step[:, 0], step[:, 1]) / gap
    speed_before = np.hypot(last[:, 0], last[:, 1]) / before
    turn = -wrap_angle(course(last[:, 0], last[:, 1]) - course(step[:, 0], step[:, 1]))  # (-pi, pi]
    return np.column_stack([speed_now - speed_before, np.degrees(turn) / gap, gap])


def sector(azimuth: np.ndarray) -> np.ndarray:
    """Azimuth sector 0..15 of azimuths (rad, clockwise from north), wedges of 22.5 deg from north."""
    return (np.floor(np.asarray(azimuth) % TWO_PI / (TWO_PI / N_SECTORS)).astype(np.int64)) % N_SECTORS


def neighbour_sectors(track_sector: np.ndarray, contact_sector: np.ndarray) -> np.ndarray:
    """True where the contact's sector is the track's or one of its two neighbours (wrapping)."""
    return (np.asarray(contact_sector) - np.asarray(track_sector) + 1) % N_SECTORS <= 2


def needed_speed(p2: np.ndarray, t2: np.ndarray, c: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """Speed (m/s) needed to go from P2 at t2 to C at tc; positions (..., 2) in m, times (...) in s."""
    d = np.asarray(c, dtype=float) - np.asarray(p2, dtype=float)
    return np.hypot(d[..., 0], d[..., 1]) / (np.asarray(tc) - np.asarray(t2))


def passes_gate(
    p2: np.ndarray, t2: np.ndarray, p2_sector: np.ndarray,
    c: np.ndarray, tc: np.ndarray, c_sector: np.ndarray,
) -> np.ndarray:
    """Sector and speed gates, elementwise over broadcastable pair arrays; boolean mask.

    Positions (..., 2) in m, times (...) in s (tc > t2), sectors from `sector`.
    """
    v = needed_speed(p2, t2, c, tc)
    return neighbour_sectors(p2_sector, c_sector) & (v >= MIN_SPEED_M_S) & (v <= MAX_SPEED_M_S)


def candidate_pairs(
    last: np.ndarray, last_time: np.ndarray, last_azimuth: np.ndarray,
    contacts: np.ndarray, contact_azimuth: np.ndarray, time: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Gated (track, contact) pairs between M tracks and the N contacts of one scan.

    ``last`` (M, 2) m, ``last_time`` (M,) s and ``last_azimuth`` (M,) rad
    describe each track's last contact; ``contacts`` (N, 2) m and
    ``contact_azimuth`` (N,) rad the scan's contacts at ``time`` s. Returns
    (track index, contact index) arrays of the pairs that pass both gates,
    ordered by track then contact.
    """
    last = np.asarray(last, dtype=float).reshape(-1, 2)
    contacts = np.asarray(contacts, dtype=float).reshape(-1, 2)
    ok = passes_gate(last[:, None, :], np.asarray(last_time, dtype=float)[:, None],
                     sector(last_azimuth)[:, None],
                     contacts[None, :, :], time, sector(contact_azimuth)[None, :])
    track, contact = np.nonzero(ok)
    return track, contact
