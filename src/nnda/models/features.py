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

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from nnda.data.sensor import TWO_PI, wrap_angle
from nnda.errors import ModelError
from nnda.validation import check_finite


@dataclass(frozen=True)
class FeatureSet:
    """A named, versioned definition of the pair features a model reads, column by column.

    A model file records the name and version of the set it was trained on;
    the loader refuses a version this nnda does not compute, and the neural
    tracker computes the set its model names (`nnda.models.feature_sets`).
    """

    name: str
    version: int
    names: tuple[str, ...]
    description: str

    @property
    def size(self) -> int:
        """Number of features (the network's inputs)."""
        return len(self.names)


#: The seed's three features [ΔV, Δα, ΔT] from the track's last two contacts and the candidate.
KINEMATIC = FeatureSet(
    "kinematic-3", 1, ("delta_speed_m_s", "course_rate_deg_s", "delta_t_s"),
    "the seed's speed change, course-change rate and time gap, from the track's last two contacts",
)

N_SECTORS = 16
MIN_SPEED_M_S = 30.0
MAX_SPEED_M_S = 400.0

#: up to this many track-contact pairs `candidate_pairs` tests every pair at once; beyond, k-d trees
#: are faster (measured crossover near 4,000-4,500 pairs, e.g. 40 tracks x 110 contacts)
DENSE_PAIRS = 4_000
#: the coarse searches (squared distances, k-d trees) widen the speed gate by this fraction, so that
#: rounding in their distances cannot drop a pair the exact gate keeps
_REACH_MARGIN = 1e-9


def course(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """Bearing (rad, clockwise from north, in (-pi, pi]) of displacements (dx east, dy north) in m."""
    return np.arctan2(dx, dy)


def _positions(name: str, p: np.ndarray, what: str = "pair features") -> np.ndarray:
    p = np.asarray(p, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ModelError(f"{what}: {name} must have shape (N, 2) [x, y] in m, got {p.shape}")
    return p


def _values(name: str, a: np.ndarray, n: int, what: str = "pair features", scalar: bool = True) -> np.ndarray:
    """``a`` as floats of shape (n,), or a scalar if ``scalar`` (broadcast by the arithmetic that uses it)."""
    a = np.asarray(a, dtype=float)
    if a.shape != (n,) and (a.shape != () or not scalar):
        raise ModelError(f"{what}: {name} must {'be a scalar or ' if scalar else ''}have shape ({n},), "
                         f"got {a.shape}")
    return a


def _all_finite(*arrays: np.ndarray) -> bool:
    """True if every value of ``arrays`` is finite, at one reduction per array and no temporary mask.

    A sum is finite only if all its terms are; a sum of finite values that
    overflows reads as False too, so False means "look closer", never "bad".
    """
    total = 0.0
    for a in arrays:
        total += a.sum()
    return math.isfinite(total)


def pair_features(
    p1: np.ndarray, t1: np.ndarray, p2: np.ndarray, t2: np.ndarray, c: np.ndarray, tc: np.ndarray,
    check: bool = True,
) -> np.ndarray:
    """Features of N pairs, shape (N, 3): [ΔV m/s, Δα deg/s, ΔT s].

    ``p1``, ``p2``, ``c``: (N, 2) positions [x east, y north] in m of each
    pair's last-but-one track contact, last track contact and candidate;
    ``t1``, ``t2``, ``tc``: (N,) or scalar, their times in s, with
    t1 < t2 < tc. Raises ModelError on wrong shapes, non-finite values or
    times out of order.

    The checks cost a few reductions when the input is good: features that
    come out finite from times in order can only come from finite input;
    anything else is examined field by field for the error message.
    ``check=False`` skips them, for callers whose arrays are already checked
    float arrays of the right shapes (the neural tracker, every scan).
    """
    n = len(p1)
    if check:
        p1, p2, c = _positions("p1", p1), _positions("p2", p2), _positions("c", c)
        if len(p2) != n or len(c) != n:
            raise ModelError(f"pair features: p1, p2 and c differ in length ({n}, {len(p2)}, {len(c)})")
        t1, t2, tc = _values("t1", t1, n), _values("t2", t2, n), _values("tc", tc, n)
    before, gap = t2 - t1, tc - t2
    last = p2 - p1
    step = c - p2
    features = np.empty((n, 3))
    with np.errstate(all="ignore"):  # bad input is reported below, by name and row
        features[:, 0] = np.hypot(step[:, 0], step[:, 1]) / gap - np.hypot(last[:, 0], last[:, 1]) / before
        turn = -wrap_angle(course(last[:, 0], last[:, 1]) - course(step[:, 0], step[:, 1]))  # (-pi, pi]
        features[:, 1] = np.degrees(turn) / gap
    features[:, 2] = gap
    if check and n and not (before.min() > 0 and gap.min() > 0 and _all_finite(features, before)):
        _check_pairs(*(np.broadcast_to(a, (n, *a.shape[1:])) for a in (p1, t1, p2, t2, c, tc)))
    return features


def _check_pairs(p1: np.ndarray, t1: np.ndarray, p2: np.ndarray, t2: np.ndarray, c: np.ndarray,
                 tc: np.ndarray) -> None:
    """Raise ModelError naming the first non-finite input, or else the first row with times out of order."""
    for name, a in (("p1", p1), ("t1", t1), ("p2", p2), ("t2", t2), ("c", c), ("tc", tc)):
        check_finite(f"pair features: {name}", a, error=ModelError)
    before, gap = t2 - t1, tc - t2
    if np.any(before <= 0) or np.any(gap <= 0):
        bad = np.flatnonzero((before <= 0) | (gap <= 0))[0]
        raise ModelError(f"pair features: times must satisfy t1 < t2 < tc; row {bad} has "
                         f"t1={t1[bad]}, t2={t2[bad]}, tc={tc[bad]}")


def sector(azimuth: np.ndarray) -> np.ndarray:
    """Azimuth sector 0..15 of azimuths (rad, clockwise from north), wedges of 22.5 deg from north."""
    return (np.floor(np.asarray(azimuth) % TWO_PI / (TWO_PI / N_SECTORS)).astype(np.int64)) % N_SECTORS


def neighbour_sectors(track_sector: np.ndarray, contact_sector: np.ndarray) -> np.ndarray:
    """True where the contact's sector is the track's or one of its two neighbours (wrapping)."""
    return (np.asarray(contact_sector) - np.asarray(track_sector) + 1) % N_SECTORS <= 2


def needed_speed(p2: np.ndarray, t2: np.ndarray, c: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """Speed (m/s) needed to go from P2 at t2 to C at tc; positions (..., 2) in m, times (...) in s."""
    c, p2 = np.asarray(c, dtype=float), np.asarray(p2, dtype=float)
    return np.hypot(c[..., 0] - p2[..., 0], c[..., 1] - p2[..., 1]) / (np.asarray(tc) - np.asarray(t2))


def passes_gate(
    p2: np.ndarray, t2: np.ndarray, p2_sector: np.ndarray,
    c: np.ndarray, tc: np.ndarray, c_sector: np.ndarray,
) -> np.ndarray:
    """Sector and speed gates, elementwise over broadcastable pair arrays; boolean mask.

    Positions (..., 2) in m, times (...) in s (tc > t2), sectors from `sector`.
    """
    v = needed_speed(p2, t2, c, tc)
    return neighbour_sectors(p2_sector, c_sector) & (v >= MIN_SPEED_M_S) & (v <= MAX_SPEED_M_S)


def _within_reach(points: np.ndarray, reach: np.ndarray, contacts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(point, contact) index pairs, sorted, with the contact within ``reach`` (M,) m (> 0) of the point
    (or a little further: callers apply the exact test). Points (M, 2) and contacts (N, 2) in m.

    Points are grouped by reach within a factor 2^(1/4) (one group per time
    since the last contact, in a tracker) and each group is searched at its
    largest reach with a pair of k-d trees, all in compiled code.
    """
    level = np.ceil(4.0 * np.log2(reach))
    tree = cKDTree(contacts)
    point, contact = [np.empty(0, np.int64)], [np.empty(0, np.int64)]
    for lv in np.unique(level):
        group = np.flatnonzero(level == lv)
        found = cKDTree(points[group]).sparse_distance_matrix(
            tree, reach[group].max() * (1.0 + _REACH_MARGIN), output_type="ndarray")
        point.append(group[found["i"]])
        contact.append(found["j"].astype(np.int64))
    point, contact = np.concatenate(point), np.concatenate(contact)
    order = np.argsort(point * len(contacts) + contact)
    return point[order], contact[order]


def candidate_pairs(
    last: np.ndarray, last_time: np.ndarray, last_azimuth: np.ndarray,
    contacts: np.ndarray, contact_azimuth: np.ndarray, time: float, check: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Gated (track, contact) pairs between M tracks and the N contacts of one scan.

    ``last`` (M, 2) m, ``last_time`` (M,) s and ``last_azimuth`` (M,) rad
    describe each track's last contact; ``contacts`` (N, 2) m and
    ``contact_azimuth`` (N,) rad the scan's contacts at ``time`` s. Returns
    (track index, contact index) int64 arrays of the pairs that pass both
    gates, ordered by track then contact. Raises ModelError on wrong shapes,
    non-finite values or a last contact not before ``time``.

    Up to `DENSE_PAIRS` track-contact pairs every pair's squared distance
    is compared with the squares of the speed gate's bounds (x the time
    since the track's last contact), with a relative margin of 1e-9 so that
    no pair the exact gate keeps is lost to rounding. Beyond that k-d trees
    list, per track, the contacts within the gate's reach, so memory grows
    with the candidates rather than with M x N. Either way only the pairs
    found get the exact `passes_gate` test, so both ways give the same
    pairs. ``check=False`` skips the input checks (for the neural tracker,
    whose arrays are already checked).
    """
    what = "candidate pairs"
    time = float(time)
    if check:
        last, contacts = _positions("last", last, what), _positions("contacts", contacts, what)
        M, N = len(last), len(contacts)
        last_time, last_azimuth = (_values(name, a, M, what, scalar=False)
                                   for name, a in (("last_time", last_time), ("last_azimuth", last_azimuth)))
        contact_azimuth = _values("contact_azimuth", contact_azimuth, N, what, scalar=False)
        if not (math.isfinite(time) and _all_finite(last, last_time, last_azimuth, contacts, contact_azimuth)):
            for name, a in (("last", last), ("last_time", last_time), ("last_azimuth", last_azimuth),
                            ("contacts", contacts), ("contact_azimuth", contact_azimuth), ("time", np.array([time]))):
                check_finite(f"{what}: {name}", a, error=ModelError)
        if M and last_time.max() >= time:
            bad = int(np.argmax(last_time >= time))
            raise ModelError(f"{what}: last_time must come before time = {time} s; row {bad} has {last_time[bad]} s")
    M, N = len(last), len(contacts)
    if M == 0 or N == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    gap = time - last_time
    if M * N <= DENSE_PAIRS:
        dx = contacts[:, 0] - last[:, 0, None]
        dy = contacts[:, 1] - last[:, 1, None]
        d2 = dx * dx + dy * dy
        lo, hi = (MIN_SPEED_M_S * (1.0 - _REACH_MARGIN)) * gap, (MAX_SPEED_M_S * (1.0 + _REACH_MARGIN)) * gap
        track, contact = np.nonzero((d2 >= (lo * lo)[:, None]) & (d2 <= (hi * hi)[:, None]))
    else:
        track, contact = _within_reach(last, MAX_SPEED_M_S * gap, contacts)
    ok = passes_gate(last[track], last_time[track], sector(last_azimuth[track]),
                     contacts[contact], time, sector(contact_azimuth[contact]))
    return track[ok], contact[ok]
