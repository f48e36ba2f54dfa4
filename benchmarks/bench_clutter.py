"""Track management in dense clutter: time per scan and what the trackers keep, per rule.

Every contact tracker (gnn, jpda, mht, and nn when given ``--model``) runs
S6 (six targets) with its clutter raised to each ``--clutter`` count per
scan, under the M/N rule, the score rule and the score rule with false tracks at a rate
(``false_tracks_per_scan`` = 0.005; `nnda.tracking.lifecycle`),
for ``--scans`` scans; a tracker is dropped from the denser settings of a
rule once it passes ``--give-up`` s per scan. Printed per row: mean and
95th-percentile ms per scan, the live tracks after the last scan,
preliminary tracks born per scan, confirmed tracks (distinct) and those
owned by clutter (by contacts: most of their contacts were clutter), and
the deletions by reason.

Usage: python benchmarks/bench_clutter.py [--clutter N]... [--scans N] [--model PATH] [--give-up S]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.tracking.output import NO_CONTACT, TrackStatus
from nnda.tracking.registry import make_tracker

#: the life-cycle settings compared, by the name printed
RULES = {"mn": {"confirmation": "mn"}, "score": {"confirmation": "score"},
         "rate": {"confirmation": "score", "false_tracks_per_scan": 0.005}}


def run(kind: str, params: dict, dataset, scans: int) -> dict:
    """One tracker over the first ``scans`` scans of ``dataset``: timings and track counts."""
    tracker = make_tracker(kind, dataset.scenario.sensors, params)
    bounds, clutter = dataset.scan_bounds(), dataset.detections.target_id < 0
    seconds, confirmed, votes = [], set(), {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for i, scan in enumerate(dataset.scans()):
            if i == scans:
                break
            start = time.perf_counter()
            out = tracker.step(scan)
            seconds.append(time.perf_counter() - start)
            confirmed.update(out.track_id[out.status == TrackStatus.CONFIRMED].tolist())
            has = out.contact != NO_CONTACT
            for tid, c in zip(out.track_id[has].tolist(), out.contact[has].tolist()):
                v = votes.setdefault(tid, [0, 0])
                v[bool(clutter[bounds[scan.index - 1] + c])] += 1
    live = getattr(tracker, "tracks", None)
    live = len(live) if live is not None else len(getattr(tracker, "leaves", None) or [])
    seconds = np.array(seconds)
    return {"mean_ms": 1e3 * seconds.mean(), "p95_ms": 1e3 * np.percentile(seconds, 95), "live": live,
            "born_per_scan": tracker.initiation.next_id / len(seconds), "confirmed": len(confirmed),
            "false": sum(1 for t in confirmed if votes.get(t, [0, 0])[1] > votes.get(t, [0, 0])[0]),
            "deletions": dict(tracker.deletions)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clutter", type=int, action="append", help="clutter points per scan (repeatable)")
    parser.add_argument("--scans", type=int, default=30)
    parser.add_argument("--model", default=None, help="model file for the neural tracker (skipped without)")
    parser.add_argument("--give-up", type=float, default=5.0, help="s per scan past which a tracker is dropped")
    args = parser.parse_args()
    counts = args.clutter or [1_000, 5_000]
    kinds = ["gnn", "jpda", "mht"] + (["nn"] if args.model else [])
    base = PRESETS["S6"]
    print(f"S6, first {args.scans} scans, seed 0 run 0; ms per scan (mean, p95), live tracks at the end, preliminary "
          f"tracks born per scan, confirmed tracks (of clutter)")
    for rule, lifecycle in RULES.items():
        slow: set[str] = set()
        for count in counts:
            ds = generate(base.model_copy(update={"clutter": base.clutter.model_copy(update={"count": count})}), 0)
            for kind in kinds:
                if kind in slow:
                    print(f"{rule:5s} {count:6d} {kind:5s} dropped (over {args.give_up:g} s per scan before)")
                    continue
                params = {"lifecycle": lifecycle, **({"model": args.model} if kind == "nn" else {})}
                r = run(kind, params, ds, args.scans)
                print(f"{rule:5s} {count:6d} {kind:5s} {r['mean_ms']:9.1f} {r['p95_ms']:9.1f} ms  live {r['live']:6d}  "
                      f"born/scan {r['born_per_scan']:8.1f}  confirmed {r['confirmed']:4d} ({r['false']} clutter)  "
                      f"{r['deletions']}", flush=True)
                if r["mean_ms"] > 1e3 * args.give_up:
                    slow.add(kind)


if __name__ == "__main__":
    main()
