"""The pedestrian study's report section (Frencl 2014, Tests 1-4), from the ``pedestrian`` jobs' results.

Test 1: the profiles' variance against the
objectivity parameter, closed form beside 10,000 draws, their polar
histograms and pdf curves. Per later test: the thesis's mean RMS beside ours with 95%
intervals, punished RMS, OSPA, GOSPA, count error and missed share (Tables
6.1 / 6.3), the paired differences, RMS per time (Figs. 6.4-6.6), the
stress scene's runtime and target count (Tables 6.2 / 6.4, Figs. 6.8 /
6.16), Test 4's estimate counts and density plots (Table 6.5, Fig. 6.19),
the verdict on each of the thesis's claims read from the intervals, and
beyond the thesis nnda's GNN, JPDA, MHT and CPHD on the stress scene's
walkers.
"""

from __future__ import annotations

import numpy as np

from nnda.reports.claims import HOLDS, NOT_MEASURED, NOT_SHOWN, REVERSED, difference, sign_verdict
from nnda.reports.pages import Figure, Section, StudyFiles
from nnda.reports.pedestrian_values import (
    THESIS_EXCESS,
    THESIS_EXCESS_POINTS,
    THESIS_RMS,
    THESIS_RUNTIME_S,
    THESIS_STRESS_SCANS,
)
from nnda.reports.text_table import DASH, TextTable, stat_cell
from nnda.study.measures import PER_RUN_BOUNDS
from nnda.study.pedestrian import BEYOND, TEST_SPECS
from nnda.study.stats import clip_interval

#: the reference work, as the column titles name it
FRENCL = "Frencl (2014)"

#: every this many scans in the per-time tables
EVERY = 5


def _f(value: float | None, fmt: str = "{:.3f}") -> str:
    return DASH if value is None else fmt.format(value)


def _cut(stats: dict, key: str) -> dict | None:
    """The per-run record ``stats[key]`` with its interval cut to the quantity's possible range
    (`nnda.study.measures.PER_RUN_BOUNDS`: a time, a count or a distance is never negative)."""
    return clip_interval(stats.get(key), *PER_RUN_BOUNDS.get(key, (-np.inf, np.inf)))


def accuracy_table(test: dict) -> TextTable:
    """Tables 6.1 / 6.3 with ours beside the thesis's, and the set measures the thesis lacks."""
    acc, thesis = test["accuracy"], THESIS_RMS.get(test["name"], {})
    rows = []
    for label, f in acc["filters"].items():
        m, r = f["mean_rms"], f["per_run"]
        tx, ty = thesis.get(label, (None, None))
        rows.append((label, _f(tx), stat_cell(m["x"], "{:.3f}"), _f(ty), stat_cell(m["y"], "{:.3f}"),
                     stat_cell(m["x_punished"], "{:.3f}"), stat_cell(m["y_punished"], "{:.3f}"),
                     stat_cell(_cut(r, "ospa"), "{:.3f}"), stat_cell(_cut(r, "gospa"), "{:.3f}"),
                     stat_cell(_cut(r, "count_error"), "{:.3f}"), stat_cell(_cut(r, "missed"), "{:.1f}", 100.0)))
    return TextTable(f"{test['title']}: mean RMS over {acc['runs']} runs of {test['accuracy_scene']}",
                     ("Filter", f"{FRENCL} RMS_x (m)", "RMS_x (m)", f"{FRENCL} RMS_y (m)", "RMS_y (m)",
                      "punished x (m)",
                      "punished y (m)", "OSPA (m)", "GOSPA (m)", "|count error|", "missed (%)"), tuple(rows),
                     "Mean over time of RMS(k), the closest estimate within the cut-off of each true point (the "
                     "thesis's min-distance method); punished: every estimate of the point counted. [95% "
                     "percentile bootstrap over runs]; OSPA, GOSPA, |extracted - true count| and the share of true "
                     "points without an estimate: means over scans, then runs [95% t-interval].")


def differences_table(test: dict) -> TextTable:
    rows = tuple((f"{d['a']} - {d['b']}", stat_cell(d["x"], "{:+.3f}"), stat_cell(d["y"], "{:+.3f}"),
                  stat_cell(d["x_punished"], "{:+.3f}"), stat_cell(d["y_punished"], "{:+.3f}"),
                  stat_cell(d["ospa"], "{:+.3f}"), stat_cell(d["duplicates"], "{:+.2f}"))
                 for d in test["accuracy"]["differences"])
    return TextTable(f"{test['name']}: paired differences (same runs)",
                     ("a - b", "RMS_x (m)", "RMS_y (m)", "punished x (m)", "punished y (m)", "OSPA (m)",
                      "points with >= 2 estimates per run"), rows,
                     "Mean-RMS differences with paired bootstrap intervals over runs; OSPA and duplicate counts: "
                     "per-run differences with t-intervals. An interval excluding 0 is a difference shown.")


def profile_table(test: dict) -> TextTable:
    acc = test["accuracy"]
    ks = list(range(EVERY, acc["n_scans"] + 1, EVERY))
    rows = []
    for label, f in acc["filters"].items():
        for key, name in (("x", "RMS_x"), ("y", "RMS_y"), ("x_punished", "punished x"), ("y_punished", "punished y")):
            rows.append((f"{label} {name}", *(_f(f["rms"][key][k - 1], "{:.2f}") for k in ks)))
    return TextTable(f"{test['name']}: RMS per time (m) over {acc['runs']} runs", ("", *(f"k={k}" for k in ks)),
                     tuple(rows))


def stress_table(test: dict) -> TextTable:
    """Tables 6.2 / 6.4 and Fig. 6.8's count bias: the thesis's runtimes and ratios beside ours."""
    st, thesis = test["stress"], THESIS_RUNTIME_S.get(test["name"], {})
    labels = list(st["filters"])
    ref_ours, ref_thesis = st["filters"][labels[0]]["runtime_s"]["mean"], thesis.get(labels[0])
    rows = []
    for label, f in st["filters"].items():
        r, t = f["per_run"], thesis.get(label)
        rows.append((label, _f(t, "{:.2f}"), _f(None if t is None else 1e3 * t / THESIS_STRESS_SCANS, "{:.0f}"),
                     stat_cell(_cut(r, "time_per_scan_s"), "{:.2f}", 1e3),
                     _f(None if t is None or ref_thesis is None else t / ref_thesis, "{:.2f}"),
                     f"{f['runtime_s']['mean'] / ref_ours:.2f}", stat_cell(r["count_bias"], "{:+.2f}"),
                     stat_cell(r["weight_bias"], "{:+.2f}"), stat_cell(_cut(r, "count_error"), "{:.2f}"),
                     stat_cell(_cut(r, "ospa"), "{:.3f}"), stat_cell(_cut(r, "gospa"), "{:.3f}")))
    return TextTable(f"{test['name']}: stress scene {test['stress_scene']} ({st['runs']} runs of {st['n_scans']} "
                     "scans)", ("Filter", f"{FRENCL} run (s)", f"{FRENCL} ms/scan", "ms/scan", f"{FRENCL} ratio",
                                "ratio",
                                "count bias", "weight bias", "|count error|", "OSPA (m)", "GOSPA (m)"), tuple(rows),
                     f"Time per scan of the filter alone [95% t-interval over runs; one process]; ratio: runtime "
                     f"over {labels[0]}'s. Count bias: extracted minus true count; weight bias: the intensity's "
                     "total weight minus the true count; means over scans, then runs.")


def count_table(test: dict) -> TextTable:
    st = test["stress"]
    ks = list(range(10, st["n_scans"] + 1, 10))
    first = next(iter(st["filters"].values()))["count"]["truth"]
    rows = [("true count", *(f"{first[k - 1]:.2f}" for k in ks))]
    for label, f in st["filters"].items():
        rows.append((f"{label} extracted", *(f"{f['count']['extracted'][k - 1]:.2f}" for k in ks)))
    return TextTable(f"{test['name']}: target count per time, mean over {st['runs']} runs (Fig. 6.8 / 6.16)",
                     ("", *(f"k={k}" for k in ks)), tuple(rows))


def excess_table(test: dict) -> TextTable:
    """Table 6.5: true points by their number of estimates, as a share of the true points counted, the thesis's
    (of its 36,000) beside ours (of as many as our runs hold), so the two compare at any run count."""
    acc = test["accuracy"]
    labels = list(acc["filters"])
    points = acc["filters"][labels[0]]["true_points"]
    rows = []
    for n in ("2", "3", ">3"):
        row = [n]
        for label in labels:
            e = acc["filters"][label]["estimates_per_point"][n]
            per_run = clip_interval(e["per_run"], *PER_RUN_BOUNDS["estimates_per_point"])
            share = {k: None if v is None else 100.0 * v * acc["runs"] / points for k, v in per_run.items()
                     if k != "n"}
            thesis = THESIS_EXCESS.get(label, {}).get(n)
            row += [_f(None if thesis is None else 100.0 * thesis / THESIS_EXCESS_POINTS, "{:.2f}"),
                    stat_cell(share, "{:.2f}")]
        rows.append(tuple(row))
    header = ["estimates of a true point"] + [
        h for label in labels for h in (f"{FRENCL}: {label} (% of {THESIS_EXCESS_POINTS:,d} points)",
                                        f"{label} (% of {points:,d} points)")]
    return TextTable(f"{test['name']}: estimate counts over {acc['runs']} runs ({points:,d} true points)",
                     tuple(header), tuple(rows),
                     f"Shares of the true points, in %: {FRENCL}'s counts over its 600 runs x 60 scans divided by "
                     f"{THESIS_EXCESS_POINTS:,d}; ours: runs x the per-run count [runs x its 95% t-interval, cut at "
                     f"0] divided by our {points:,d} true points. {FRENCL}'s own counts (2 / 3 / >3 estimates): "
                     + "; ".join(f"{label} {' / '.join(str(v) for v in counts.values())}"
                                 for label, counts in THESIS_EXCESS.items())
                     + ". Estimates within the cut-off of the true point count as its own.")


def beyond_table(beyond: dict) -> TextTable:
    """Beyond the thesis: nnda's contact trackers and the CPHD on the stress scene, beside two of its PHDs."""
    rows = tuple((label, stat_cell(_cut(r, "ospa"), "{:.3f}"), stat_cell(_cut(r, "gospa"), "{:.3f}"),
                  stat_cell(_cut(r, "count_error"), "{:.2f}"), stat_cell(r["count_bias"], "{:+.2f}"),
                  stat_cell(_cut(r, "time_per_scan_s"), "{:.2f}", 1e3))
                 for label, r in ((label, f["per_run"]) for label, f in beyond["filters"].items()))
    return TextTable(f"Beyond the thesis: every tracker on {beyond['scene']} ({beyond['runs']} runs of "
                     f"{beyond['n_scans']} scans)", ("Tracker", "OSPA (m)", "GOSPA (m)", "|count error|",
                                                    "count bias", "ms/scan"), rows,
                     "GNN, JPDA and MHT run the thesis's CV as a one-model IMM on the same fixes, with nnda's "
                     "two-point initiation (window 0-4.5 m/s) and M/N 3-of-4 life cycle; their confirmed tracks are "
                     "the estimates. Means over scans, then runs [95% t-interval].")


def _claim(text: str, stats: list[dict], sign: int) -> str:
    """``text`` with the verdict of its differences' intervals (`nnda.reports.claims.sign_verdict`)."""
    return text + {HOLDS: ": **holds**", REVERSED: ": **fails** (a difference is shown the other way)",
                   NOT_SHOWN: ": **not shown** (an interval includes 0)",
                   NOT_MEASURED: ": **not measured** (too few runs for an interval)"}[sign_verdict(stats, sign)]


def _diff(test: dict, a: str, b: str, key: str) -> dict:
    """The difference a - b of ``key`` (sign flipped when the results hold b - a)."""
    for d in test["accuracy"]["differences"]:
        if (d["a"], d["b"]) == (a, b):
            return d[key]
        if (d["a"], d["b"]) == (b, a):
            s = d[key]
            return {"mean": None if s["mean"] is None else -s["mean"],
                    "ci_low": None if s["ci_high"] is None else -s["ci_high"],
                    "ci_high": None if s["ci_low"] is None else -s["ci_low"]}
    raise KeyError(f"{test['name']}: no difference {a} - {b}")


def _runtime_diff(test: dict, a: str, b: str) -> dict:
    """a's runtime per stress run less b's, as an interval: disjoint t-intervals show a difference."""
    return difference(*(_cut(test["stress"]["filters"][x], "runtime_s") for x in (a, b)))


def comparisons(test: dict) -> list[tuple[str, list[dict], int]]:
    """The thesis's conclusions for this test as (claim, the differences that decide it, the claimed sign)."""
    labels = list(test["accuracy"]["filters"])
    out = []
    if test["name"] == "test2":
        gm, ek, uk = labels
        out.append(("EK-PHD + NCSHT is the most accurate (lower RMS_x and RMS_y than GM-PHD and UK-PHD)",
                    [_diff(test, ek, o, k) for o in (gm, uk) for k in ("x", "y")], -1))
        out.append(("UK-PHD is clearly worse than EK-PHD (higher RMS_x and RMS_y)",
                    [_diff(test, uk, ek, k) for k in ("x", "y")], +1))
    if test["name"] == "test3":
        cv, nc, hm = labels
        out.append(("the HM-map model gives the most precise estimates (lower RMS_x and RMS_y than CV and NCSHT)",
                    [_diff(test, hm, o, k) for o in (cv, nc) for k in ("x", "y")], -1))
        out.append(("modified NCSHT beats CV (lower RMS_x and RMS_y)", [_diff(test, nc, cv, k) for k in ("x", "y")],
                    -1))
    if test["name"] == "test4":
        no, hm = labels
        out.append(("the HM map gives fewer duplicate estimates (points with 2 or more per run)",
                    [_diff(test, hm, no, "duplicates")], -1))
        out.append(("the HM map narrows the scatter (lower punished RMS_y across the corridor)",
                    [_diff(test, hm, no, "y_punished")], -1))
    if "stress" in test and test["name"] == "test2":
        first, second = list(test["stress"]["filters"])[:2]
        out.append((f"{first} runs faster than {second} (Table 6.2)", [_runtime_diff(test, first, second)], -1))
        out.append(("every filter overestimates the target count (Fig. 6.8)",
                    [f["per_run"]["count_bias"] for f in test["stress"]["filters"].values()], +1))
    return out


def verdicts(test: dict) -> list[str]:
    """The thesis's conclusions for this test (`comparisons`), each read from the intervals."""
    return [_claim(text, stats, sign) for text, stats, sign in comparisons(test)]


def _png(fig) -> bytes:
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def density_figure(test: dict) -> bytes:
    """Fig. 6.19: the estimates of every run binned on the corridor, one panel per filter (log colour)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    items = list(test["density"].items())
    fig, axes = plt.subplots(len(items), 1, figsize=(9, 2.6 * len(items)), squeeze=False)
    for ax, (label, d) in zip(axes[:, 0], items, strict=True):
        counts = np.asarray(d["counts"], dtype=float)
        im = ax.imshow(np.where(counts > 0, counts, np.nan), origin="lower", norm=LogNorm(vmin=1),
                       extent=(0, d["width_m"], 0, d["height_m"]), aspect="equal", cmap="viridis")
        ax.set_ylim(15, 35)
        ax.set_title(label)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        fig.colorbar(im, ax=ax, label="estimates per m^2")
    return _png(fig)


def rms_figure(test: dict) -> bytes:
    """RMS_x(k) and RMS_y(k), plain and punished, of every filter (Figs. 6.4-6.6 / 6.12-6.14)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4), sharey=True)
    for ax, axis in zip(axes, ("x", "y"), strict=True):
        for i, (label, f) in enumerate(test["accuracy"]["filters"].items()):
            k = np.arange(1, len(f["rms"][axis]) + 1)
            plain = np.array([np.nan if v is None else v for v in f["rms"][axis]])
            punished = np.array([np.nan if v is None else v for v in f["rms"][f"{axis}_punished"]])
            ax.plot(k, plain, color=f"C{i}", label=label)
            ax.plot(k, punished, color=f"C{i}", ls=":", lw=1)
        ax.set_title(f"RMS_{axis} (dotted: punished)")
        ax.set_xlabel("scan k")
    axes[0].set_ylabel("m")
    axes[0].legend(fontsize=8)
    return _png(fig)


def variance_table(test1: dict) -> TextTable:
    """Test 1: each profile's closed-form variance beside its draws', and whether the interval holds it."""
    rows = []
    for kind, entries in test1["variance"].items():
        for e in entries:
            s = e["sampled"]
            inside = s["ci_low"] <= e["closed"] <= s["ci_high"]
            rows.append((kind, f"{e['parameter']:g}", f"{e['closed']:.4f}", stat_cell(s, "{:.4f}"),
                         "yes" if inside else "no"))
    return TextTable(f"Test 1: variance of the heading deviation (rad^2) against the objectivity parameter, "
                     f"{test1['draws']:,d} draws each", ("profile", "parameter", "closed form", "draws",
                                                        "closed form in the interval"), tuple(rows),
                     "Draws: the mean of delta^2 (the mean is 0) [95% t-interval]. Parameters: drop n, leaf lambda, "
                     "balloon sigma (rad).")


def test1_figure(test1: dict) -> bytes:
    """Test 1's figures in one: polar histograms of the draws (top), pdf curves (middle), variance (bottom)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(12, 11))
    grid = np.asarray(test1["grid"])
    for i, h in enumerate(test1["histograms"]):
        ax = fig.add_subplot(3, 3, 1 + i, projection="polar")
        counts = np.asarray(h["counts"])
        width = 2 * np.pi / len(counts)
        ax.bar(-np.pi + width * (np.arange(len(counts)) + 0.5), counts, width=width, color="C0", edgecolor="white")
        ax.set_title(f"{h['kind']} {h['parameter']:g}: {test1['draws']:,d} draws", fontsize=9)
    for i, (kind, curves) in enumerate(test1["pdfs"].items()):
        ax = fig.add_subplot(3, 3, 4 + i)
        for c in curves:
            ax.plot(grid, c["density"], label=f"{c['parameter']:.3g}")
        ax.set_title(f"{kind} pdf", fontsize=9)
        ax.set_xlabel("deviation (rad)")
        ax.legend(fontsize=7)
    for i, (kind, entries) in enumerate(test1["variance"].items()):
        ax = fig.add_subplot(3, 3, 7 + i)
        p = [e["parameter"] for e in entries]
        ax.plot(p, [e["closed"] for e in entries], "-", color="C1", label="closed form")
        ax.plot(p, [e["sampled"]["mean"] for e in entries], "o", color="C0", ms=3, label="draws")
        if kind == "drop":
            ax.set_xscale("log")
        ax.set_title(f"{kind}: variance (rad^2)", fontsize=9)
        ax.set_xlabel({"drop": "n", "leaf": "lambda", "balloon": "sigma (rad)"}[kind])
        ax.legend(fontsize=7)
    fig.tight_layout()
    return _png(fig)


def pedestrian_section(section, results: dict) -> tuple[object, list]:
    """Fill ``section`` (a `nnda.reports.pages.Section`) from a pedestrian study's results; returns
    it and its figures (`nnda.reports.pages.Figure`)."""
    cfg = results["config"]
    birth = ("measurement-driven (rate 0.1 per scan over the unexplained contacts)" if cfg["birth"] == "measurement"
             else "the thesis's oracle birth (the walkers' true first states at the first scan only)")
    section.text(f"The thesis's filters on our drawing of its scenes (`nnda.data.pedestrian.scenes`), every filter "
                 f"on the same runs (seed {cfg['seed']}); birth {birth}; cut-off c = {cfg['cutoff_m']:g} m for the "
                 f"estimate-to-truth assignment, OSPA and GOSPA (p = 2); {cfg['bootstrap']} bootstrap resamples. "
                 f"Its jobs took {results['runtime_s']:.0f} s of compute. The thesis's maps and trajectories exist "
                 "only as figures, so its numbers are a reference, not a target: the verdicts compare filters within "
                 "our runs.")
    figures = []
    claims = []
    if "test1" in results:
        section.text("**Test 1: the heading profiles' objectivity**")
        section.table(variance_table(results["test1"]), "pedestrian-test1-variance")
        fig = Figure("pedestrian-test1-profiles.png", "Test 1: polar histograms, pdfs and variance of the profiles",
                     test1_figure, (results["test1"],))
        section.figure(fig)
        figures.append(fig)
    for test in results["tests"]:
        section.text(f"**{test['title']}**")
        section.table(accuracy_table(test), f"pedestrian-{test['name']}-accuracy")
        section.table(differences_table(test), f"pedestrian-{test['name']}-differences")
        section.table(profile_table(test), f"pedestrian-{test['name']}-profile")
        fig = Figure(f"pedestrian-{test['name']}-rms.png", f"{test['name']}: RMS per time", rms_figure, (test,))
        section.figure(fig)
        figures.append(fig)
        if "stress" in test:
            section.table(stress_table(test), f"pedestrian-{test['name']}-stress")
            section.table(count_table(test), f"pedestrian-{test['name']}-count")
        if test["name"] == "test4":
            section.table(excess_table(test), "pedestrian-test4-excess")
            fig = Figure("pedestrian-test4-density.png", "Test 4: density of the estimates (Fig. 6.19)",
                         density_figure, (test,))
            section.figure(fig)
            figures.append(fig)
        found = verdicts(test)
        claims += found
        section.text("\n".join(f"* {v}" for v in found))
    if "beyond" in results:
        section.table(beyond_table(results["beyond"]), "pedestrian-beyond")
    if claims:
        section.text("**The thesis's claims, read from the intervals:**\n\n" + "\n".join(f"* {c}" for c in claims))
    return section, figures


def _ordered(mapping: dict, labels: list[str]) -> dict:
    return {label: mapping[label] for label in labels if label in mapping}


def in_study_order(results: dict) -> dict:
    """``results`` with every per-filter mapping in the study's filter order (summary.json sorts its keys; the
    tables, figures and conclusions read the filters in the thesis's order)."""
    tests = []
    for test in results["tests"]:
        labels = [f.label for f in TEST_SPECS[test["name"]].filters]
        test = {**test, "filters": _ordered(test["filters"], labels),
                "accuracy": {**test["accuracy"], "filters": _ordered(test["accuracy"]["filters"], labels)}}
        if "stress" in test:
            test["stress"] = {**test["stress"], "filters": _ordered(test["stress"]["filters"], labels)}
        if "density" in test:
            test["density"] = _ordered(test["density"], labels)
        tests.append(test)
    out = {**results, "tests": tests}
    if "beyond" in results:
        out["beyond"] = {**results["beyond"], "filters": _ordered(results["beyond"]["filters"],
                                                                  [f.label for f in BEYOND])}
    return out


def sections(study: StudyFiles, figures: list[Figure]) -> list[Section]:
    """The pedestrian study's section of a study report, with its figures."""
    section, drawn = pedestrian_section(Section("pedestrian", "Pedestrian study (Frencl 2014)", [], []),
                                        in_study_order(study.results("pedestrian")))
    figures += drawn
    return [section]
