"""Scaling against Stone Soup: time per scan of our trackers and the Stone Soup peers.

The scenarios are bench_trackers' scaling set (`scaling_settings`): S6 with
100 -> 1,000 -> 10,000 clutter points per scan, then 6 -> 50 -> 200 targets
with 100 clutter points, SCALING_SCANS scans each, one seeded run. Every
tracker runs every setting in this process, one after the other, so the
ratios ours / peer compare like with like. Along each axis a tracker is
stopped once a scan passes ``--give-up`` s (default 10 s): the scan that
crossed it is reported, larger settings are not run. A run still going after
``--hard-stop`` s in all (default 120 s: a scan that alone would take minutes,
e.g. an exact JPDA on a huge cluster) is interrupted and counted as stopped;
its time per scan is then only bounded below, by the hard stop over the
scans begun ('>' in the tables, a triangle in the plot). Before any timing,
every tracker runs each axis's smallest setting once, untimed, so loading
its compiled kernels (numba's cache, function by function as a run first
needs them: a few scans are not enough, the first confirmations and
deletions load more) is not counted in its first setting.

Output: a table of ms per scan and GOSPA (mean over scans, m; only for
finished runs), the ratio of the nearest Stone Soup equivalent's time to
ours (gnn <-> stonesoup-gnn, jpda <-> stonesoup-jpda; mht and nn against the
fastest peer that finished), and a log-log plot (PNG) of time per scan
against clutter and against targets, with the 2 s scan period marked; then
each tracker's slopes, the least-squares slope of log(time per scan) against
log(clutter) and against log(targets) over the settings it finished (1: time
grows in proportion, 2: with the square).

``--trackers`` picks ours (default gnn, jpda, mht, nn; also nn-life, the
neural tracker with the demo's life-cycle options, and the PHD filters
gmphd, ekphd, cphd), ``--no-peers`` leaves the peers out, ``--clutter``
sets the clutter axis (default 100,1000,10000; e.g. 1000,2000,5000 for the
slope near the limit) and ``--targets`` the targets axis (0: not run).
Below the slopes, each tracker's worst scan at each axis's largest setting.
The machine's other work makes one run's time vary by 10-30 % over minutes,
enough to move a slope over 1,000 -> 5,000 by 0.2 or more; so the whole sweep
runs ``--repeats`` times (default 3; a run that took over REPEAT_UNDER_S
seconds only once) and each setting's fastest run counts.

The neural tracker needs a model: ``--model PATH`` (written by ``nnda
train``); without it the neural tracker is skipped with a note. The peers
need Stone Soup (``pip install 'nnda[peers]'``); without it they are skipped
with a note.
Usage: python benchmarks/bench_scaling.py [--model PATH] [--out scaling.png] [--trackers gnn,gmphd]
       [--clutter 1000,2000,5000] [--targets 0] [--no-peers] [--scans N] [--repeats R]
"""

from __future__ import annotations

import argparse
import math
import signal
from contextlib import contextmanager
from typing import NamedTuple

import numpy as np

from bench_trackers import GIVE_UP_S, LIFE, SCALING_SCANS, many_targets, params_for, scaling_settings, time_run
from nnda.data.generator import generate
from nnda.errors import ConfigError
from nnda.peers import require_stonesoup
from nnda.peers.parameters import EQUIVALENT
from nnda.study.metrics import run_metrics
from nnda.tracking.registry import PEERS, make_tracker

OURS = ["gnn", "jpda", "mht", "nn"]
#: what --trackers may name besides the registry's trackers: name -> (tracker, its options besides the model)
ALIASES = {"nn-life": ("nn", LIFE)}
NEURAL = {"nn", "nn-life"}
#: runs that took longer than this (s, all scans) are timed once, whatever ``--repeats`` says
REPEAT_UNDER_S = 30.0


class Interrupted(Exception):
    """A run went on past the hard stop."""


class Result(NamedTuple):
    """One tracker on one setting: mean s per scan (None: not run), GOSPA mean over scans (m; None
    unless every scan ran), stopped (this or a smaller setting passed the give-up time), and whether
    the mean is only a lower bound (run interrupted at the hard stop)."""

    mean_s: float | None
    gospa_m: float | None
    stopped: bool
    lower_bound: bool = False
    worst_s: float | None = None

    @property
    def finished(self) -> bool:
        """Every scan of the setting ran (the GOSPA is only computed then)."""
        return self.gospa_m is not None


@contextmanager
def hard_stop(seconds: float):
    """Raise Interrupted in this (main) thread once ``seconds`` of wall time have passed."""
    def fire(_sig, _frame):
        raise Interrupted

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def settings_for(scans: int, clutter: list[int], targets: list[int]):
    """(axis, value, scenario) of the runs: `scaling_settings`' S6 with each of ``clutter`` points per scan, then
    its many-target scene with each of ``targets`` (the defaults give `scaling_settings` itself)."""
    base = next(scenario for axis, _, scenario in scaling_settings(scans) if axis == "clutter")
    return ([("clutter", c, base.model_copy(update={"clutter": base.clutter.model_copy(update={"count": c})}))
             for c in clutter] + [("targets", n, many_targets(n, seed=n, scans=scans)) for n in targets])


def kind_params(name: str, model: str | None) -> tuple[str, dict | None]:
    """The registry's tracker and options of a ``--trackers`` name (`ALIASES`)."""
    if name in ALIASES:
        kind, options = ALIASES[name]
        return kind, {**options, **(params_for(kind, model) or {})}
    return name, params_for(name, model)


def warm_up(names, model, settings, hard) -> None:
    """Run every tracker untimed over each axis's smallest setting (its ``scans`` scans)."""
    first = {}
    for axis, _, scenario in settings:
        first.setdefault(axis, scenario)
    for scenario in first.values():
        dataset = generate(scenario, seed=0)  # another realisation than the timed runs' (seed 1)
        for name in names:
            kind, params = kind_params(name, model)
            tracker = make_tracker(kind, dataset.scenario.sensor, params)
            try:
                with hard_stop(hard):
                    for scan in dataset.scans():
                        tracker.step(scan)
            except Interrupted:
                print(f"  {name}: warm-up interrupted at the hard stop ({hard:g} s)", flush=True)


def measure(names, model, settings, give_up, hard, repeats=1):
    """{(tracker, axis, value): Result}; along each axis a tracker stops as the module docstring says. Then
    ``repeats`` - 1 more passes over the settings time the short runs again (`again`)."""
    warm_up(names, model, settings, hard)
    results = {}
    stopped = {(n, axis): False for n in names for axis in ("clutter", "targets")}
    for axis, value, scenario in settings:
        dataset = generate(scenario, seed=1)
        for name in names:
            if stopped[name, axis]:
                results[name, axis, value] = Result(None, None, True)
                continue
            outputs = []
            try:
                with hard_stop(hard):
                    t = time_run(*kind_params(name, model), dataset, give_up, outputs)
                done = len(t) == dataset.n_scans
                gospa = float(run_metrics(dataset, outputs).gospa.mean()) if done else None
                r = Result(float(t.mean()), gospa, bool(t.max() > give_up), worst_s=float(t.max()))
            except Interrupted:
                r = Result(hard / (len(outputs) + 1), None, True, True)
            stopped[name, axis] = r.stopped
            results[name, axis, value] = r
            print(f"  {name:<15s} {axis}={value:<6d} {'>' if r.lower_bound else ' '}{r.mean_s * 1e3:10.1f} ms/scan"
                  f"  GOSPA {'-' if r.gospa_m is None else f'{r.gospa_m:.1f}'}", flush=True)
    for _ in range(repeats - 1):
        again(names, model, settings, results)
    return results


def again(names, model, settings, results) -> None:
    """Time once more every finished run of ``results`` that took under REPEAT_UNDER_S s, one pass over all the
    settings (the machine's slow minutes then fall on every setting alike, not on one), keeping the faster
    time: of the same scans, the least disturbed run is the best estimate of their cost."""
    for axis, value, scenario in settings:
        dataset = generate(scenario, seed=1)
        for name in names:
            r = results[name, axis, value]
            if not r.finished or r.lower_bound or r.mean_s * dataset.n_scans >= REPEAT_UNDER_S:
                continue
            t = time_run(*kind_params(name, model), dataset)
            if t.mean() < r.mean_s:
                results[name, axis, value] = r._replace(mean_s=float(t.mean()), worst_s=float(t.max()))


def reference(name: str, axis: str, value: int, peers: list[str], results) -> str | None:
    """The peer ``name`` is compared with at one setting: its equivalent, else the fastest finished peer."""
    if EQUIVALENT.get(name) in peers:
        return EQUIVALENT[name]
    timed = [p for p in peers if results[p, axis, value].mean_s is not None]
    return min(timed, key=lambda p: results[p, axis, value].mean_s) if timed else None


def table(names, peers, results, settings, scans) -> None:
    print(f"\nms per scan (GOSPA m) over {scans} scans; x = not run (stopped on a smaller setting), "
          f"* = stopped during this setting (mean of the scans run), > = interrupted at the hard stop (lower bound)")
    print(f"{'tracker':<15s}" + "".join(f"{f'{a}={v}':>22s}" for a, v in settings))
    for name in names:
        cells = []
        for a, v in settings:
            r = results[name, a, v]
            if r.mean_s is None:
                cells.append(f"{'x':>22s}")
                continue
            g = "" if r.gospa_m is None else f" ({r.gospa_m:.0f})"
            text = ('>' if r.lower_bound else '') + f"{r.mean_s * 1e3:.1f}{g}" + ('*' if r.stopped else '')
            cells.append(f"{text:>22s}")
        print(f"{name:<15s}" + "".join(cells))
    if not peers:
        return
    print("\nspeed ratio = peer time / our time, same process (> 1: ours faster); * = the peer stopped during "
          "this setting, ratio of its mean over the scans it ran; > = a lower bound (peer interrupted)")
    print(f"{'ours':<8s}{'peer':<16s}" + "".join(f"{f'{a}={v}':>16s}" for a, v in settings))
    for name in names:
        if name in peers:
            continue
        for peer in sorted({reference(name, a, v, peers, results) for a, v in settings} - {None}):
            cells = []
            for a, v in settings:
                ours, theirs = results[name, a, v].mean_s, results[peer, a, v]
                if ours is None or reference(name, a, v, peers, results) != peer:
                    cells.append(f"{'-':>16s}")
                elif theirs.mean_s is None:
                    cells.append(f"{'stopped':>16s}")
                else:
                    text = (('>' if theirs.lower_bound else '') + f"{theirs.mean_s / ours:.0f}x"
                            + ('*' if theirs.stopped else ''))
                    cells.append(f"{text:>16s}")
            print(f"{name:<8s}{peer:<16s}" + "".join(cells))


def slope(points: list[tuple[int, float]]) -> float | None:
    """Least-squares slope of log(time) against log(setting) over (setting, s per scan) points; None under two."""
    if len(points) < 2:
        return None
    x, y = np.log([v for v, _ in points]), np.log([t for _, t in points])
    return float(np.polyfit(x, y, 1)[0])


def slopes(names, results, settings) -> dict[tuple[str, str], float | None]:
    """{(tracker, axis): slope} over the settings of that axis the tracker finished (`slope`)."""
    out = {}
    for name in names:
        for axis in ("clutter", "targets"):
            points = [(v, results[name, a, v].mean_s) for a, v in settings
                      if a == axis and results[name, a, v].finished]
            out[name, axis] = slope(points)
    return out


def slope_table(names, results, settings) -> None:
    fitted = slopes(names, results, settings)
    print("\nslope of log(time per scan) against log(clutter) and log(targets), least squares over the "
          "settings finished (n); 1 = linear, 2 = quadratic")
    print(f"{'tracker':<15s}{'vs clutter':>14s}{'vs targets':>14s}")
    for name in names:
        cells = []
        for axis in ("clutter", "targets"):
            n = sum(a == axis and results[name, a, v].finished for a, v in settings)
            s = fitted[name, axis]
            cells.append(f"{'-' if s is None or math.isnan(s) else f'{s:.2f}'} ({n})")
        print(f"{name:<15s}" + "".join(f"{c:>14s}" for c in cells))


def worst_table(names, results, settings) -> None:
    """Each tracker's worst scan (ms) at each axis's largest setting (- : not finished)."""
    last = {}
    for a, v in settings:
        last[a] = max(v, last.get(a, v))
    print("\nworst scan (ms) at the largest setting of each axis")
    print(f"{'tracker':<15s}" + "".join(f"{f'{a}={v}':>16s}" for a, v in last.items()))
    for name in names:
        cells = [results[name, a, v] for a, v in last.items()]
        print(f"{name:<15s}" + "".join(f"{'-' if r.worst_s is None else f'{r.worst_s * 1e3:.1f}':>16s}" for r in cells))


def plot(names, peers, results, settings, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, axis in zip(axes, ("clutter", "targets")):
        xs = [v for a, v in settings if a == axis]
        if not xs:
            continue
        for name in names:
            rs = [(v, results[name, axis, v]) for v in xs if results[name, axis, v].mean_s is not None]
            if not rs:
                continue
            line, = ax.loglog([v for v, _ in rs], [r.mean_s for _, r in rs], marker="o",
                              linestyle="--" if name in peers else "-", label=name)
            low = [(v, r.mean_s) for v, r in rs if r.lower_bound]
            if low:
                ax.loglog(*zip(*low), marker="^", markersize=11, linestyle="none", color=line.get_color())
        ax.axhline(2.0, color="grey", linewidth=0.8, linestyle=":")
        ax.text(xs[0], 2.2, "scan period 2 s", fontsize=8, color="grey")
        ax.set_xlabel("clutter points per scan (S6, 6 targets)" if axis == "clutter" else
                      "targets (100 clutter points per scan)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("time per scan (s)")
    axes[1 if any(a == "targets" for a, _ in settings) else 0].legend(fontsize=8)
    fig.suptitle("nnda trackers (solid) and Stone Soup peers (dashed): time per scan")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"\nplot written to {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", help="model file for the neural tracker")
    parser.add_argument("--scans", type=int, default=SCALING_SCANS)
    parser.add_argument("--give-up", type=float, default=GIVE_UP_S, help="s per scan that stops a tracker")
    parser.add_argument("--hard-stop", type=float, default=120.0, help="s after which one scan is interrupted")
    parser.add_argument("--out", default="bench_scaling.png", help="PNG of the log-log plot")
    parser.add_argument("--trackers", default=",".join(OURS),
                        help=f"our trackers, comma-separated: the registry's names or {', '.join(ALIASES)}")
    parser.add_argument("--clutter", default="100,1000,10000", help="clutter points per scan of the clutter axis")
    parser.add_argument("--targets", default="6,50,200", help="targets of the targets axis (0: not run)")
    parser.add_argument("--no-peers", action="store_true", help="leave the Stone Soup peers out")
    parser.add_argument("--repeats", type=int, default=3, help=f"passes over the settings (runs over "
                        f"{REPEAT_UNDER_S:g} s only once); each setting's fastest run counts")
    args = parser.parse_args()
    names = [n for n in args.trackers.split(",") if n not in NEURAL or args.model]
    if not args.model and NEURAL & set(args.trackers.split(",")):
        print("note: the neural tracker is skipped (give --model PATH, a file written by `nnda train`)")
    peers = []
    if not args.no_peers:
        try:
            require_stonesoup("bench_scaling's peers")
            peers = list(PEERS)
        except ConfigError as exc:
            print(f"note: the Stone Soup peers are skipped: {exc}")
    names += peers
    full = settings_for(args.scans, [int(v) for v in args.clutter.split(",") if int(v)],
                        [int(v) for v in args.targets.split(",") if int(v)])
    settings = [(a, v) for a, v, _ in full]
    print(f"trackers: {', '.join(names)}; {args.scans} scans per setting, stop past {args.give_up:g} s/scan")
    results = measure(names, args.model, full, args.give_up, args.hard_stop, args.repeats)
    table(names, peers, results, settings, args.scans)
    slope_table(names, results, settings)
    worst_table(names, results, settings)
    plot(names, peers, results, settings, args.out)


if __name__ == "__main__":
    main()
