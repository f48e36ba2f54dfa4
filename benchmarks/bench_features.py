"""The neural tracker's per-scan feature path: compiled (`nnda.models.feature_kernels`) against numpy.

Per scan the neural tracker gates its tracks' candidates (`candidate_pairs`),
computes the three kinematic features (`pair_features`), the IMM-innovation columns
(`innovation_features`) and the context columns (`with_context`). They
were numpy before; that formulation is kept here (`numpy_*`) as the
reference, and both run in this process on the same synthetic scans: K
tracks 6-24 km out, one contact near each track's prediction and clutter
uniform over 5-30 km. Printed: microseconds per scan of the whole path and
of the candidate search, the ratio, and the agreement (pairs equal, the
largest feature difference relative to its column's largest value).
The last sizes time the candidate search alone (the scans of
bench_trackers' scaling part, up to 10,000 tracks x 10,000 contacts).

Usage: python benchmarks/bench_features.py [--quick]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np
from scipy.spatial import cKDTree

from nnda.data.presets import PRESETS
from nnda.filters.imm import IMM
from nnda.filters.kalman import mahalanobis_2x2
from nnda.models.context import D2_CAP, D2_COLUMN, with_context
from nnda.models.features import MAX_SPEED_M_S, MIN_SPEED_M_S, N_SECTORS, candidate_pairs, pair_features
from nnda.models.innovation import IMM_INNOVATION, innovation_features

TWO_PI = 2.0 * np.pi
DENSE_PAIRS, REACH_MARGIN = 4_000, 1e-9  # the numpy search's switch to k-d trees and its coarse margin


def numpy_sector(azimuth):
    return (np.floor(np.asarray(azimuth) % TWO_PI / (TWO_PI / N_SECTORS)).astype(np.int64)) % N_SECTORS


def numpy_gate(p2, t2, s2, c, tc, sc):
    v = np.hypot(c[..., 0] - p2[..., 0], c[..., 1] - p2[..., 1]) / (np.asarray(tc) - np.asarray(t2))
    return ((sc - s2 + 1) % N_SECTORS <= 2) & (v >= MIN_SPEED_M_S) & (v <= MAX_SPEED_M_S)


def numpy_candidates(last, last_time, last_azimuth, contacts, contact_azimuth, time):
    """`candidate_pairs` before it was compiled: every pair's squared distance, or k-d trees beyond DENSE_PAIRS."""
    M, N = len(last), len(contacts)
    gap = time - last_time
    if M * N <= DENSE_PAIRS:
        dx = contacts[:, 0] - last[:, 0, None]
        dy = contacts[:, 1] - last[:, 1, None]
        d2 = dx * dx + dy * dy
        lo, hi = (MIN_SPEED_M_S * (1.0 - REACH_MARGIN)) * gap, (MAX_SPEED_M_S * (1.0 + REACH_MARGIN)) * gap
        track, contact = np.nonzero((d2 >= (lo * lo)[:, None]) & (d2 <= (hi * hi)[:, None]))
    else:
        reach = MAX_SPEED_M_S * gap
        level = np.ceil(4.0 * np.log2(reach))
        tree = cKDTree(contacts)
        track, contact = [np.empty(0, np.int64)], [np.empty(0, np.int64)]
        for lv in np.unique(level):
            group = np.flatnonzero(level == lv)
            found = cKDTree(last[group]).sparse_distance_matrix(
                tree, reach[group].max() * (1.0 + REACH_MARGIN), output_type="ndarray")
            track.append(group[found["i"]])
            contact.append(found["j"].astype(np.int64))
        track, contact = np.concatenate(track), np.concatenate(contact)
        order = np.argsort(track * N + contact)
        track, contact = track[order], contact[order]
    ok = numpy_gate(last[track], last_time[track], numpy_sector(last_azimuth[track]),
                    contacts[contact], time, numpy_sector(contact_azimuth[contact]))
    return track[ok], contact[ok]


def numpy_kinematic(p1, t1, p2, t2, c, tc):
    before, gap = t2 - t1, tc - t2
    last, step = p2 - p1, c - p2
    out = np.empty((len(p1), 3))
    out[:, 0] = np.hypot(step[:, 0], step[:, 1]) / gap - np.hypot(last[:, 0], last[:, 1]) / before
    change = np.arctan2(last[:, 0], last[:, 1]) - np.arctan2(step[:, 0], step[:, 1])
    out[:, 1] = np.degrees(-((change + np.pi) % TWO_PI - np.pi)) / gap
    out[:, 2] = gap
    return out


def numpy_innovation(imm, pred, track, contacts, kinematic, age):
    gate = imm.combined_measurement(pred)
    nu = imm.measurement.residual(contacts, gate.z[track])
    S = gate.S[track]
    out = np.empty((len(track), IMM_INNOVATION.size))
    out[:, :3] = kinematic
    out[:, 3] = nu[:, 0] / np.sqrt(S[:, 0, 0])
    out[:, 4] = nu[:, 1] / np.sqrt(S[:, 1, 1])
    out[:, 5] = mahalanobis_2x2(nu, gate.S_inv[track])
    out[:, 6] = gate.log_det_S[track]
    out[:, 7] = pred.state.mu[track, 1]
    out[:, 8] = age
    return out


def numpy_ranked(key, d2):
    n = len(key)
    order = np.lexsort((d2, key))
    k, v = key[order], d2[order]
    first = np.empty(n, bool)
    first[0] = True
    np.not_equal(k[1:], k[:-1], out=first[1:])
    start = np.flatnonzero(first)
    end = np.empty_like(start)
    end[:-1], end[-1] = start[1:], n
    group = np.cumsum(first) - 1
    at = start[group]
    out = np.empty((3, n))
    out[0, order] = rank = np.arange(n) - at
    out[1, order] = size = (end - start)[group]
    out[2, order] = np.where(rank > 0, v[at], np.where(size > 1, v[np.minimum(at + 1, n - 1)], D2_CAP))
    return out


def numpy_with_context(features, track, contact):
    d2 = np.minimum(features[:, D2_COLUMN], D2_CAP)
    n = len(d2)
    both = numpy_ranked(np.concatenate([track, contact + (track.max() + 1)]), np.concatenate([d2, d2]))
    ctx = np.column_stack([both[0, :n], d2 - both[2, :n], both[1, :n], both[1, n:] - 1, both[2, n:]])
    return np.hstack([features, ctx])


def scan(n_tracks: int, n_contacts: int, seed: int = 0):
    """Tracks (last two contacts, their IMM prediction at the scan) and the scan's contacts (module docstring)."""
    rng = np.random.default_rng(seed)
    imm = IMM.for_sensor(PRESETS["S1"].sensor)
    r, b = rng.uniform(6e3, 2.4e4, n_tracks), rng.uniform(0, TWO_PI, n_tracks)
    v, h = rng.uniform(70, 250, n_tracks), rng.uniform(0, TWO_PI, n_tracks)
    xy = lambda t: np.stack([r * np.sin(b) + v * t * np.sin(h), r * np.cos(b) + v * t * np.cos(h)], -1)  # noqa: E731
    polar = lambda p: np.stack([np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 0], p[:, 1]) % TWO_PI], -1)  # noqa: E731
    t2 = 10.0 - rng.choice([2.0, 4.0], n_tracks, p=[0.8, 0.2])
    p1, p2 = xy(t2 - 2.0), xy(t2)
    pred = imm.predict(imm.initialise(polar(p1), polar(p2), t2 - 2.0, t2), 10.0 - t2)
    near = xy(10.0)[: min(n_tracks, n_contacts)] + rng.normal(0, 100.0, (min(n_tracks, n_contacts), 2))
    n_clutter = n_contacts - len(near)
    rc, ac = np.sqrt(rng.uniform(5e3**2, 3e4**2, n_clutter)), rng.uniform(0, TWO_PI, n_clutter)
    contacts = np.concatenate([near, np.column_stack([rc * np.sin(ac), rc * np.cos(ac)])])
    z = polar(contacts)
    age = np.full(n_tracks, 10.0) - (t2 - 2.0)
    return dict(imm=imm, pred=pred, p1=p1, t1=t2 - 2.0, p2=p2, t2=t2, az2=polar(p2)[:, 1], xy=contacts, z=z,
                time=10.0, age=age)


def path(s, gate, kinematic, innovation, context):
    """One scan's features as the neural tracker computes them, through the given functions."""
    track, cand = gate(s["p2"], s["t2"], s["az2"], s["xy"], s["z"][:, 1], s["time"])
    f = kinematic(s["p1"][track], s["t1"][track], s["p2"][track], s["t2"][track], s["xy"][cand], s["time"])
    f = innovation(s["imm"], s["pred"], track, s["z"][cand], f, s["age"][track])
    return track, cand, context(f, track, cand)


COMPILED = (lambda *a: candidate_pairs(*a, check=False), lambda *a: pair_features(*a, check=False),
            innovation_features, with_context)
NUMPY = (numpy_candidates, numpy_kinematic, numpy_innovation, numpy_with_context)


def best_us(fn, number: int) -> float:
    return min(timeit.repeat(fn, number=number, repeat=5)) / number * 1e6


def main(sizes, search_sizes) -> None:
    print("feature path per scan (candidates, kinematic features, IMM innovation, context), us, best of 5")
    print(f"{'tracks':>7s}{'contacts':>9s}{'pairs':>7s}{'numpy':>10s}{'compiled':>10s}{'speed-up':>9s}"
          f"{'search np':>11s}{'search':>9s}   max |diff| / column max")
    for K, N in sizes + search_sizes:
        s = scan(K, N)
        gate_args = (s["p2"], s["t2"], s["az2"], s["xy"], s["z"][:, 1], s["time"])
        a, b = numpy_candidates(*gate_args), COMPILED[0](*gate_args)
        assert all(np.array_equal(u, v) for u, v in zip(a, b)), "candidate pairs differ"
        number = max(1, int(2e4 / (K + N)))
        search = [best_us(lambda: f(*gate_args), number) for f in (numpy_candidates, COMPILED[0])]
        if (K, N) in search_sizes:
            print(f"{K:7d}{N:9d}{len(a[0]):7d}{'':>10s}{'':>10s}{'':>9s}{search[0]:11.0f}{search[1]:9.0f}"
                  f"   pairs equal ({search[0] / search[1]:.1f}x)")
            continue
        x, y = path(s, *NUMPY), path(s, *COMPILED)
        assert np.array_equal(x[2][:, [9, 11, 12]], y[2][:, [9, 11, 12]]), "ranks or counts differ"
        diff = float(np.max(np.abs(x[2] - y[2]) / np.maximum(np.abs(x[2]).max(axis=0), 1e-300))) if x[2].size else 0.0
        whole = [best_us(lambda: path(s, *fns), number) for fns in (NUMPY, COMPILED)]
        print(f"{K:7d}{N:9d}{len(a[0]):7d}{whole[0]:10.1f}{whole[1]:10.1f}{whole[0] / whole[1]:8.1f}x"
              f"{search[0]:11.1f}{search[1]:9.1f}   {diff:.1e}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small scans only (checks that it runs)")
    args = parser.parse_args()
    if args.quick:
        main([(15, 100)], [(100, 1_000)])
    else:
        main([(5, 100), (15, 100), (40, 110), (200, 300)], [(800, 1_000), (10_000, 10_000)])
