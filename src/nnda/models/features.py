"""Pair features of the neural association and candidate gating (Vargas Avila (2015), eqs. 5.4-5.6).

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

Δα stays in deg/s, the unit in which the thesis defines the network input
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

from nnda.errors import ModelError
from nnda.filters.imm_kernels import kernel_array
from nnda.models import feature_kernels
from nnda.models.feature_kernels import MAX_SPEED_M_S as MAX_SPEED_M_S
from nnda.models.feature_kernels import MIN_SPEED_M_S as MIN_SPEED_M_S
from nnda.models.feature_kernels import N_SECTORS as N_SECTORS
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


#: Vargas Avila (2015)'s three features [ΔV, Δα, ΔT] from the track's last two contacts and the candidate.
KINEMATIC = FeatureSet(
    "kinematic-3", 1, ("delta_speed_m_s", "course_rate_deg_s", "delta_t_s"),
    "the thesis's speed change, course-change rate and time gap, from the track's last two contacts",
)

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

    The features are computed in one compiled loop
    (`feature_kernels.kinematic`), which also flags whether they all came
    out finite from times in order; only from finite input can they, and
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
    t1, t2, tc = _per_pair(t1, n), _per_pair(t2, n), _per_pair(tc, n)
    features, good = feature_kernels.kinematic(p1, t1, p2, t2, c, tc)
    if check and not good:
        _check_pairs(p1, t1, p2, t2, c, tc)
    return features


def _per_pair(t: np.ndarray | float, n: int) -> np.ndarray:
    """Times (n,) from a scalar or an (n,) array (float)."""
    if isinstance(t, np.ndarray) and t.ndim == 1 and t.dtype == np.float64:  # the tracker's, every scan
        return t
    return np.full(n, t, dtype=float) if np.ndim(t) == 0 else np.asarray(t, dtype=float)


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


def _flat(*arrays: np.ndarray) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The broadcast shape of ``arrays`` and each broadcast to it, flattened (contiguous; a broadcast one
    copied, so the kernels never see numpy's read-only broadcast views)."""
    shape = np.broadcast_shapes(*(a.shape for a in arrays))
    return shape, [a.ravel() if a.shape == shape else np.broadcast_to(a, shape).flatten() for a in arrays]


def sector(azimuth: np.ndarray) -> np.ndarray:
    """Azimuth sector 0..15 of azimuths (rad, clockwise from north), wedges of 22.5 deg from north."""
    azimuth = kernel_array(azimuth)  # a dataset's read-only column is copied: the kernel compiles once
    return feature_kernels.sectors(azimuth.ravel()).reshape(azimuth.shape)


def neighbour_sectors(track_sector: np.ndarray, contact_sector: np.ndarray) -> np.ndarray:
    """True where the contact's sector is the track's or one of its two neighbours (wrapping)."""
    shape, (s2, sc) = _flat(np.asarray(track_sector, np.int64), np.asarray(contact_sector, np.int64))
    return feature_kernels.neighbours(s2, sc).reshape(shape)


def needed_speed(p2: np.ndarray, t2: np.ndarray, c: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """Speed (m/s) needed to go from P2 at t2 to C at tc; positions (..., 2) in m, times (...) in s."""
    c, p2 = np.asarray(c, dtype=float), np.asarray(p2, dtype=float)
    shape, flat = _flat(p2[..., 0], p2[..., 1], np.asarray(t2, float), c[..., 0], c[..., 1], np.asarray(tc, float))
    return feature_kernels.speeds(*flat).reshape(shape)


def passes_gate(
    p2: np.ndarray, t2: np.ndarray, p2_sector: np.ndarray,
    c: np.ndarray, tc: np.ndarray, c_sector: np.ndarray,
) -> np.ndarray:
    """Sector and speed gates, elementwise over broadcastable pair arrays; boolean mask.

    Positions (..., 2) in m, times (...) in s (tc > t2), sectors from `sector`.
    """
    c, p2 = np.asarray(c, dtype=float), np.asarray(p2, dtype=float)
    shape, (px, py, t2, s2, cx, cy, tc, sc) = _flat(
        p2[..., 0], p2[..., 1], np.asarray(t2, float), np.asarray(p2_sector, np.int64),
        c[..., 0], c[..., 1], np.asarray(tc, float), np.asarray(c_sector, np.int64))
    return feature_kernels.in_gate(px, py, t2, s2, cx, cy, tc, sc).reshape(shape)


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

    The search is compiled (`feature_kernels.candidates`): the contacts are
    binned on a grid of about the speed gate's reach, and each track tests
    only the contacts of the cells its reach overlaps, with the exact gate of
    `passes_gate`; so the work and memory grow with the candidates rather
    than with M x N, and the pairs are those of the exact gate over every
    track-contact pair. ``check=False`` skips the input checks (for the
    neural tracker, whose arrays are already checked).
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
    last, last_time, last_azimuth, contacts, contact_azimuth = (  # C order: the kernel compiles once
        kernel_array(a) for a in (last, last_time, last_azimuth, contacts, contact_azimuth))
    return feature_kernels.candidates(last, last_time, last_azimuth, contacts, contact_azimuth, time)
