"""The report's "Target count" section [cardinality]: how well each tracker counts the targets.

Read from ``cardinality.parquet`` (`nnda.study.cardinality`) and
``summary.json``:

* per scenario, a figure of the estimated target count over time for every
  tracker (its confirmed tracks; for the PHD family also the filter's own
  expected count), mean over runs with the band holding the central 95% of
  runs (2.5-97.5 percentiles), the true count drawn;
* a table of the target-count error mean |N_est - N| per scan (the
  registry's ``count_error``: confirmed tracks against the targets present)
  for every tracker and scenario, with its t-interval over runs;
* for the trackers that report their own cardinality, a table of it per
  scenario: mean |N_hat - N| of the filter's expected count N_hat (t-interval
  over runs), the *spread over runs* (per scan the standard deviation over
  runs of N_hat - N, then the mean over scans) of N_hat and of the confirmed
  count, and the filter's *own* standard deviation (the CPHD: of its
  cardinality distribution; a PHD, which keeps none, implies a Poisson count
  of variance N_hat), mean over runs and scans;
* sentences computed from those numbers comparing each cardinalised filter
  (a tracker that records a distribution: the CPHD) with each uncardinalised
  one (a mean but no distribution: GM-, EK-, UK-PHD, Stone Soup's GM-PHD).

A study directory written before the counts were recorded has no
``cardinality.parquet``: the section then holds the count-error table and
says how to get the rest.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from nnda.reports import study_figures
from nnda.reports.text_table import DASH, TextTable, interval, stat_cell
from nnda.study.cardinality import CARDINALITY_FILE, Counts, read_cardinality
from nnda.study.measures import measure
from nnda.study.stats import mean_ci

COUNT_ERROR = measure("count_error")
#: how the filter-cardinality table reads its numbers (counts per scan)
FMT = "{:.2f}"


def _nan_reduce(f: Callable, a: np.ndarray, **kw) -> np.ndarray | float:
    """``f`` (a nan-aware numpy reduction) without the warnings of all-NaN slices (they give NaN)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return f(a, **kw)


def run_spread(estimate: np.ndarray, true: np.ndarray) -> float:
    """Mean over scans of the standard deviation over runs (ddof 1) of estimate - true, (runs, scans)
    arrays; NaN with fewer than two runs."""
    if estimate.shape[0] < 2:
        return float("nan")
    return float(_nan_reduce(np.nanmean, _nan_reduce(np.nanstd, estimate - true, axis=0, ddof=1)))


def filter_row(c: Counts, confidence: float) -> dict:
    """The numbers of one cardinality-reporting tracker on one scenario (module docstring)."""
    own_var = c.filter_variance if c.filter_variance is not None else c.filter_mean  # a PHD: Poisson
    per_run_error = _nan_reduce(np.nanmean, np.abs(c.filter_mean - c.true), axis=1)
    return {
        "error": mean_ci(per_run_error.tolist(), confidence, 0.0),
        "spread": run_spread(c.filter_mean, c.true),
        "spread_confirmed": run_spread(c.confirmed, c.true),
        "own_sd": float(_nan_reduce(np.nanmean, np.sqrt(own_var))),
        "cardinalised": c.filter_variance is not None,
    }


def _num(v: float) -> str:
    return DASH if not np.isfinite(v) else FMT.format(v)


def count_error_table(summary: dict) -> TextTable:
    """Mean |N_est - N| (confirmed tracks) per scan: a row per tracker, a column per scenario."""
    scenarios = summary["scenarios"]
    rows = tuple((t["label"], *(stat_cell(sc["trackers"][t["label"]]["metrics"].get(COUNT_ERROR.key),
                                          COUNT_ERROR.fmt) for sc in scenarios)) for t in summary["trackers"])
    runs = max((v["runs"] for sc in scenarios for v in sc["trackers"].values()), default=0)
    return TextTable("Target-count error: mean abs(confirmed tracks - targets present) per scan",
                     ("Tracker", *(sc["name"] for sc in scenarios)), rows,
                     f"Mean over scans, then over {runs} run(s) [{summary['confidence']:.0%} t-interval]: "
                     f"`{COUNT_ERROR.key}` of the results tables.")


def filter_table(rows: dict[tuple[str, str], dict], confidence: float, runs: int) -> TextTable:
    """The cardinality-reporting trackers' own counts, a row per (scenario, tracker)."""
    body = tuple((f"{s}: {t}", interval(r["error"]["mean"], r["error"]["ci_low"], r["error"]["ci_high"], FMT),
                  _num(r["spread"]), _num(r["spread_confirmed"]),
                  _num(r["own_sd"]) + ("" if r["cardinalised"] else " (Poisson)"))
                 for (s, t), r in rows.items())
    return TextTable("The filters' own target count N_hat",
                     ("Scenario: tracker", "Mean error abs(N_hat - N)", "Spread over runs of N_hat - N",
                      "Spread over runs of confirmed - N", "Own standard deviation"), body,
                     f"Per scan, then mean over scans; {runs} run(s), [{confidence:.0%} t-interval] over runs. "
                     f"Spread over runs: the standard deviation over runs at each scan. Own standard deviation: "
                     f"of the CPHD's cardinality distribution, or sqrt(N_hat) for a PHD (a Poisson count).")


def _ratio_text(a: float, b: float) -> str:
    if not (np.isfinite(a) and np.isfinite(b)) or b == 0:
        return "not comparable"
    return f"{a / b:.2f} times"


def comparisons(rows: dict[tuple[str, str], dict], summary: dict) -> list[str]:
    """Sentences comparing each cardinalised filter's spread and count error with each uncardinalised one's,
    from the numbers of ``rows`` and ``summary`` (nothing here is fixed text about which is better)."""
    labels = list(dict.fromkeys(t for _, t in rows))
    card = [t for t in labels if all(r["cardinalised"] for (_, u), r in rows.items() if u == t)]
    phd = [t for t in labels if t not in card]
    if not card or not phd:
        return ["The study has no pair of a cardinalised filter (one that records a cardinality distribution, "
                "the CPHD) and a PHD filter without one, so there is no spread to compare."]
    scenarios = list(dict.fromkeys(s for s, _ in rows))
    level = f"{summary['confidence']:.0%}"
    errors = {sc["name"]: sc["trackers"] for sc in summary["scenarios"]}
    out = []
    for a in card:
        for b in phd:
            both = [s for s in scenarios if (s, a) in rows and (s, b) in rows]
            sa = np.array([rows[s, a]["spread"] for s in both])
            sb = np.array([rows[s, b]["spread"] for s in both])
            ok = np.isfinite(sa) & np.isfinite(sb)
            if not ok.any():
                out.append(f"{a} against {b}: the spread over runs needs at least two runs.")
                continue
            ma, mb = float(sa[ok].mean()), float(sb[ok].mean())
            own_a = float(np.mean([rows[s, a]["own_sd"] for s in both]))
            own_b = float(np.mean([rows[s, b]["own_sd"] for s in both]))
            smaller = int((sa[ok] < sb[ok]).sum())
            text = (f"**{a} against {b}**: over runs, {a}'s own count N_hat - N spreads by a standard deviation of "
                    f"{ma:.2f} per scan (mean over {int(ok.sum())} scenario(s)), {b}'s by {mb:.2f}: "
                    f"{_ratio_text(ma, mb)} {b}'s, smaller in {smaller} of {int(ok.sum())} scenario(s). "
                    f"The filters' own standard deviation: {own_a:.2f} ({a}'s cardinality distribution) against "
                    f"{own_b:.2f} (the Poisson count {b} implies), {_ratio_text(own_a, own_b)}.")
            stats = [(errors[s][a]["metrics"].get(COUNT_ERROR.key), errors[s][b]["metrics"].get(COUNT_ERROR.key))
                     for s in both]
            stats = [(x, y) for x, y in stats if x and y and x["mean"] is not None and y["mean"] is not None]
            if stats:
                lower = sum(x["mean"] < y["mean"] for x, y in stats)
                apart = sum(x["ci_high"] is not None and y["ci_low"] is not None and x["ci_high"] < y["ci_low"]
                            for x, y in stats)
                text += (f" Target-count error of the confirmed tracks: {a}'s below {b}'s in {lower} of "
                         f"{len(stats)} scenario(s), with the {level} intervals apart in {apart}.")
            out.append(text)
    return out


def target_counts(section, out: str | Path, summary: dict, scan_times: dict[str, np.ndarray],
                  figure: Callable[..., object]):
    """Fill ``section`` (a `nnda.reports.pages.Section`) and return it; ``figure(name, caption, draw, args)``
    makes a report figure and registers it for drawing."""
    trackers = [t["label"] for t in summary["trackers"]]
    section.text("How many targets each tracker reports, scan by scan, against the true count: its confirmed "
                 "tracks and, for the PHD filters, the filter's own expected count N_hat (a PHD: the total weight "
                 "of its intensity; the CPHD: the mean of its cardinality distribution).")
    section.table(count_error_table(summary), "count-error")
    if not (Path(out) / CARDINALITY_FILE).is_file():
        section.text(f"This study directory has no `{CARDINALITY_FILE}` (written before nnda recorded the "
                     f"target count of every scan): run the study again (`nnda compare --resume` reruns its "
                     f"jobs) for the figures and the filters' own counts.")
        return section
    counts = read_cardinality(out)
    for sc in summary["scenarios"]:
        mine = {t: counts[sc["name"], t] for t in trackers if (sc["name"], t) in counts}
        if not mine:
            continue
        section.figure(figure(f"target_count_{sc['name']}.png",
                              f"{sc['name']}: estimated target count per scan, mean over runs and the central 95% "
                              f"of runs (2.5-97.5 percentiles), true count in black", study_figures.target_count,
                              (sc["name"], scan_times[sc["name"]], mine, trackers)))
    rows = {(sc["name"], t): filter_row(counts[sc["name"], t], summary["confidence"])
            for sc in summary["scenarios"] for t in trackers
            if (sc["name"], t) in counts and counts[sc["name"], t].filter_mean is not None}
    if not rows:
        section.text("No tracker of this study reports its own cardinality (none of the PHD family ran).")
        return section
    runs = max(counts[k].runs for k in rows)
    section.table(filter_table(rows, summary["confidence"], runs), "filter-cardinality")
    section.text("\n".join(f"* {line}" for line in comparisons(rows, summary)))
    return section
