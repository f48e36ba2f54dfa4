"""The track-before-detect study's report section (Bruno, Araújo & Pavlov), from the ``tbd`` jobs' results.

Per PTCR: the divergence table (divergent runs with their Clopper-Pearson
interval beside the paper's count, detection rate, steady-state error,
likelihood evaluations and milliseconds per frame), the detect-then-track
chain's trackers in the same table, the Fisher tests between filters and
between the chain and each filter, and the per-frame RMSE excluding and
including divergent runs; then the verdict on the paper's claim (the APF
with 5,000 particles diverges less than resample-move with 8,000) read from
the tests, the cost of each filter and each filter's divergent runs against
the paper's acceptance (a rate at most the upper 95% bound of the paper's
count, called inside or outside with both counts and Fisher's p), and the
chain's verdict (what detecting first loses against the APF at each PTCR);
the exit and re-entry tables and each filter's false detections and missed
re-acquisitions there; and a figure of a few frames of one run with the
first filter's particles, estimate and truth.
"""

from __future__ import annotations

import numpy as np

from nnda.files import read_json
from nnda.reports.pages import Figure, Section, StudyFiles
from nnda.reports.text_table import DASH, TextTable, interval, stat_cell
from nnda.study.checksums import read_checked
from nnda.study.tbd import PAPER_DIVERGENCES
from nnda.study.tbd_runs import SNAPSHOT_FILE, SNAPSHOT_FORMAT, SNAPSHOT_VERSION

#: every this many frames in the RMSE tables
PROFILE_EVERY = 2
#: a Fisher p below this is called a difference
ALPHA = 0.05


def _pct(d: dict) -> str:
    return interval(d["rate"], d["ci_low"], d["ci_high"], "{:.1f}", 100.0)


def _chain_label(name: str) -> str:
    return f"detect + {name}"


def _estimators(s: dict) -> list[tuple[str, dict]]:
    """(row label, scores) of every filter, then of every chain tracker (results of version 1 have none)."""
    return [*s["filters"].items(), *((_chain_label(n), c) for n, c in s.get("chain", {}).items())]


def _divergence_table(s: dict, conf: float) -> TextTable:
    rows = []
    for label, f in s["filters"].items():
        d = f["divergence"]
        paper = s["paper"].get(label)
        rows.append((label, f"{d['count']}/{d['runs']}", _pct(d),
                     DASH if paper is None else f"{paper['divergence']['count']}/100",
                     DASH if paper is None else f"{paper['fisher_p']:.2f}",
                     DASH if f["declared_present"] is None else f"{f['declared_present']:.1%}",
                     stat_cell(f["steady_error"], "{:.2f}"), f"{f['evaluations_per_frame']:,.0f}",
                     f"{f['ms_per_frame']:.2f}"))
    for name, c in s.get("chain", {}).items():
        d = c["divergence"]
        rows.append((_chain_label(name), f"{d['count']}/{d['runs']}", _pct(d), DASH, DASH,
                     DASH if c["declared_present"] is None else f"{c['declared_present']:.1%}",
                     stat_cell(c["steady_error"], "{:.2f}"),
                     f"{s['detector']['correlations_per_frame']:,} (correlations)", f"{c['ms_per_frame']:.2f}"))
    chain = ("; detect + gnn/mht = the matched-filter detector's detections tracked by nnda's GNN or MHT "
             "(declared present = a confirmed track; its cost is the detector's template correlations, every "
             "aspect at every position, and the detector's and the tracker's ms/frame)") if s.get("chain") else ""
    return TextTable(f"PTCR {s['ptcr_db']:g} dB: divergence, detection and cost over {s['runs']} runs of "
                     f"{s['frames']} frames",
                     ("Filter", "diverged", f"rate % [{conf:.0%} CP]", "paper", "Fisher p vs paper",
                      "declared present", "steady error (px)", "likelihoods/frame", "ms/frame"),
                     tuple(rows),
                     "CP = Clopper-Pearson exact interval; declared present = share of truth-present frames "
                     "after acquisition with P(z=0) < 0.5; steady error = per-run mean position error over the "
                     f"last frames, runs that did not diverge [{conf:.0%} t-interval]; ms/frame per run (the "
                     f"runs are filtered in batches){chain}.")


def _pairs_table(s: dict, conf: float) -> TextTable:
    count = {label: e["divergence"]["count"] for label, e in _estimators(s)}
    rows = [(f"{p['a']} vs {p['b']}", f"{count[p['a']]} vs {count[p['b']]}", f"{p['fisher_p']:.3f}", DASH)
            for p in s["pairs"]]
    for p in s.get("chain_vs_filters", []):
        a = _chain_label(p["chain"])
        rows.append((f"{a} vs {p['filter']}", f"{count[a]} vs {count[p['filter']]}", f"{p['fisher_p']:.3f}",
                     stat_cell(p["present_difference"], "{:+.1f}", 100.0)))
    return TextTable(f"PTCR {s['ptcr_db']:g} dB: divergence counts compared (Fisher's exact test, two-sided)",
                     ("Pair", "diverged", "p", f"declared present, points [{conf:.0%} paired t]"), tuple(rows),
                     "declared present, points = the first's per-run share of truth-present frames after "
                     "acquisition declared present less the second's, mean over runs (percentage points).")


def _rmse_table(s: dict, key: str) -> TextTable:
    frames = list(range(1, s["frames"] + 1, PROFILE_EVERY))
    if frames[-1] != s["frames"]:
        frames.append(s["frames"])
    rows = []
    for label, f in _estimators(s):
        for axis in ("x", "y"):
            rows.append((f"{label} {axis}", *(DASH if (v := f[key][axis][n - 1]) is None else f"{v:.2f}"
                                             for n in frames)))
    which = "excluding divergent runs" if key == "rmse" else "all runs, divergent ones included"
    note = "detect + gnn/mht: over the runs with a confirmed track in the frame." if s.get("chain") else ""
    return TextTable(f"PTCR {s['ptcr_db']:g} dB: RMSE (pixels) by frame, {which}", ("", *(f"n={n}" for n in frames)),
                     tuple(rows), note)


def _exit_reentry_tables(er: dict, conf: float) -> tuple[TextTable, TextTable]:
    def frames(stat: dict) -> str:
        never = f", never {stat['never']}/{stat['events']}" if stat["never"] else ""
        return stat_cell(stat, "{:.1f}") + never

    estimators = _estimators(er)
    rows = tuple((label, DASH if f["detection_rate"] is None else f"{f['detection_rate']:.1%}",
                  DASH if f["false_detection_rate"] is None else f"{f['false_detection_rate']:.1%}",
                  frames(f["first_acquire"]), frames(f["reacquire"]), frames(f["exit_declared"]))
                 for label, f in estimators)
    summary = TextTable(f"Exit and re-entry: {er['runs']} runs of {er['frames']} frames at {er['ptcr_db']:g} dB "
                        f"(the target leaves the frame at {er['speed']:g} px per time unit, a new one enters at "
                        f"frame {er['reentry_frame']})",
                        ("Filter", "present frames declared present", "absent frames declared present",
                         "frames to acquire", "frames to reacquire", "frames to declare the exit"), rows,
                        f"Frames counted from the entry (or the first target-free frame) as 1 [{conf:.0%} "
                        "t-interval over runs]; acquired = declared present within the divergence distance.")
    every = 5
    idx = list(range(0, er["frames"], every))
    first = next(iter(er["filters"].values()))
    profile = [("truth present", *(f"{first['truth_present_by_frame'][n]:.0%}" for n in idx))]
    profile += [(label, *(f"{f['present_by_frame'][n]:.0%}" for n in idx)) for label, f in estimators]
    return summary, TextTable("Exit and re-entry: share of runs declaring the target present, by frame",
                              ("", *(f"n={n + 1}" for n in idx)), tuple(profile))


def _chain_text(s: dict, cfg: dict) -> str:
    """The detector's figures at one PTCR and, when the chain ran, the trackers' settings."""
    det = s["detector"]
    text = (f"The conventional chain's per-frame detector (matched filter, pfa {det['pfa']:g} per position and "
            f"aspect) on the same frames: a detection within {cfg['divergence_px']:g} px of the target in "
            f"{det['p_detection']:.1%} of its frames, {det['false_per_frame']:.2f} false detections per frame, "
            f"{det['ms_per_frame']:.2f} ms per frame.")
    chain = s.get("chain")
    if not chain:
        return text + " Its detections were not tracked (the study's `chain` is off)."
    first = next(iter(chain.values()))["settings"]
    life = first["params"]["lifecycle"]
    text += (f" Its detections are tracked as position fixes in pixels, one scan per frame: one CV model "
             f"(sigma_q = sqrt(q / dt) = {first['sigma_q']:.1f} px per time unit^2), measurement sd "
             f"{first['measurement_sd']:g} px, confirmation {life['m']}/{life['n']}, deletion after "
             f"{life['max_misses']} misses in a row (from the detector's P_D {first['detection_probability']:.2f} "
             f"at the target)")
    mht = chain.get("mht")
    if mht is not None:
        p = mht["settings"]["params"]
        text += f"; MHT with P_D {p['pd']:.2f} and clutter density {p['clutter_density']:.1e} per px^2"
    return text + "."


def _chain_verdicts(settings: list[dict]) -> list[str]:
    """Per chain tracker, what detecting first loses against the APF (else the first filter) at each PTCR, read
    from the divergence counts (Fisher) and the paired difference in present frames declared present."""
    out = []
    names = list(settings[0].get("chain", {})) if settings else []
    for name in names:
        parts, losses = [], []
        for s in settings:
            filters = s["filters"]
            ref = next((k for k in filters if filters[k]["filter"] == "apf"), next(iter(filters)))
            c, f = s["chain"][name], filters[ref]
            vs = next(v for v in s["chain_vs_filters"] if v["chain"] == name and v["filter"] == ref)
            diff = vs["present_difference"]
            if diff["mean"] is None:
                continue
            covers = diff["ci_low"] is None or diff["ci_low"] <= 0 <= diff["ci_high"]
            word = "fewer" if diff["mean"] < 0 else "more"
            sig = "the interval covers 0" if covers else "significant"
            losses.append(f"{abs(diff['mean']) * 100:.1f} points {word} at {s['ptcr_db']:g} dB "
                          f"({stat_cell(diff, '{:+.1f}', 100.0)}, {sig})")
            differs = "a difference" if vs["fisher_p"] < ALPHA else "no significant difference"
            parts.append(f"at {s['ptcr_db']:g} dB {c['divergence']['count']}/{c['divergence']['runs']} against "
                         f"{f['divergence']['count']}/{f['divergence']['runs']} divergent runs ({differs}, Fisher "
                         f"p = {vs['fisher_p']:.2f}), steady error (its frames with a track) "
                         f"{stat_cell(c['steady_error'], '{:.2f}')} against "
                         f"{stat_cell(f['steady_error'], '{:.2f}')} px")
        if parts:
            out.append(f"**{_chain_label(name)}** against {ref}: {'; '.join(parts)}. Of the present frames after "
                       f"acquisition, detecting first declares {' and '.join(losses)} present than {ref} "
                       f"(percentage points, paired over the runs).")
    return out


def filter_q(cfg: dict) -> float:
    """The filters' acceleration-noise intensity of a study's config: its own, else (None, or results written
    before it was a setting) the scene's."""
    q = cfg["tbd"].get("q")
    return cfg["scene"]["q"] if q is None else q


def _acceptance(s: dict, label: str, cfg: dict) -> str | None:
    """Whether ``label``'s divergent runs at one PTCR are inside the paper's acceptance: a rate at most the upper
    Clopper-Pearson bound of the paper's count of 100 (~9% for 3/100), with both counts and Fisher's p; outside
    with the frames' own q, the measured cause. None for a filter the paper has no count of."""
    paper = s["paper"].get(label)
    if paper is None:
        return None
    d, theirs, p = s["filters"][label]["divergence"], paper["divergence"], paper["fisher_p"]
    counts = (f"{d['count']}/{d['runs']} divergent runs ({d['rate']:.1%}) against the paper's "
              f"{theirs['count']}/{theirs['runs']} (Fisher p = {p:.3f})")
    bound = f"at most {theirs['ci_high']:.1%}, the upper {cfg['confidence']:.0%} bound of the paper's count"
    where = f"{label} at {s['ptcr_db']:g} dB"
    if d["rate"] <= theirs["ci_high"]:
        return f"{where}: {counts}, inside the paper's acceptance ({bound})."
    text = f"**{where} is outside the paper's acceptance**: {counts}; the acceptance is {bound}."
    q, scene = filter_q(cfg), cfg["scene"]
    if q == scene["q"]:
        step = (q * scene["dt"]) ** 0.5
        text += (f" The filters use the frames' own q = {q:g} px^2 per time unit^3, under which a particle's "
                 f"velocity moves by only {step:.2f} px per time unit a frame (the birth prior's spread is "
                 f"{scene['birth_velocity_sd']:g}): a cloud that has collapsed onto a wrong velocity drifts off "
                 "the target or loses it, nnda's measured cause of excess divergences (the study's default "
                 "filter q lets the velocity move).")
    return text


def _verdict(s: dict, cfg: dict) -> str:
    """The paper's claim at one PTCR (APF 5,000 diverges less than RS 8,000, at lower cost) from the counts, and
    each filter's count against the paper's acceptance."""
    f = s["filters"]
    apf = next((k for k in f if f[k]["filter"] == "apf"), None)
    rs = next((k for k in f if f[k]["filter"] == "rs"), None)
    accepted = " ".join(t for label in f if (t := _acceptance(s, label, cfg)) is not None)
    if apf is None or rs is None:
        return f"PTCR {s['ptcr_db']:g} dB: the study has no APF and RS pair to compare. {accepted}".rstrip()
    da, dr = f[apf]["divergence"], f[rs]["divergence"]
    p = next(x["fisher_p"] for x in s["pairs"] if {x["a"], x["b"]} == {apf, rs})
    cost = f[rs]["evaluations_per_frame"] / f[apf]["evaluations_per_frame"]
    if p < ALPHA:
        better = apf if da["count"] < dr["count"] else rs
        head = f"**{better} diverges significantly less** ({da['count']} vs {dr['count']}, Fisher p = {p:.3f})"
    else:
        head = (f"**no significant difference**: {apf} {da['count']}/{da['runs']} vs {rs} {dr['count']}/{dr['runs']} "
                f"divergent runs (Fisher p = {p:.2f})")
    steady = (f"steady-state error {stat_cell(f[apf]['steady_error'], '{:.2f}')} vs "
              f"{stat_cell(f[rs]['steady_error'], '{:.2f}')} px")
    paper = PAPER_DIVERGENCES.get(s["ptcr_db"])
    said = "" if paper is None else f" (paper: {paper['apf']}/100 vs {paper['rs']}/100)"
    return (f"PTCR {s['ptcr_db']:g} dB{said}: {head}; {steady}; RS costs {cost:.1f} x the APF's likelihood "
            f"evaluations per frame. {accepted}").rstrip()


def _exit_reentry_text(er: dict) -> str:
    """Each filter's false detections and missed re-acquisitions in the exit and re-entry scenario, against the
    paper's claim of no false detection in the target-free frames."""
    parts = []
    for label, f in er["filters"].items():
        if f["false_detection_rate"] is None:
            continue
        again = f["reacquire"]
        parts.append(f"{label} declares {f['false_detection_rate']:.1%} of the {f['absent_frames']} target-free "
                     f"frames present and never reacquires {again['never']} of {again['events']} re-entries")
    if not parts:
        return ""
    return ("The paper reports no false detection in the target-free frames of this scenario (no figures); "
            f"{'; '.join(parts)}.")


def tbd_section(section, results: dict):
    """Fill ``section`` (a `nnda.reports.pages.Section`) from a TBD study's results."""
    cfg = results["config"]
    scene, conf = cfg["scene"], cfg["confidence"]
    section.text(
        f"Every filter runs on the same {cfg['runs']} simulated sequences of {scene['frames']} frames of "
        f"{scene['rows']} x {scene['cols']} pixels at each PTCR (seed {cfg['seed']}; GMRF beta_h {scene['beta_h']:g}, "
        f"beta_v {scene['beta_v']:g}, sigma_c {scene['sigma_c']:g}, {cfg['tbd']['gmrf']} parameters; "
        f"{len(scene['aspects'])} aspects of nnda's 7 x 7 vehicle template; the filters' acceleration-noise "
        f"intensity q = {filter_q(cfg):g} px^2 per time unit^3, the frames' {scene['q']:g}). The paper reports "
        "3/100 (APF, 5,000 particles) against 5/100 (RS, 8,000) divergent runs at 6.5 dB and 2/100 against "
        "3/100 at 8.1 dB, and "
        f"calls the APF equivalent or slightly better. A run diverged when in each of its last "
        f"{cfg['divergence_frames']} frames the filter declared the target absent or was more than "
        f"{cfg['divergence_px']:g} px from it. Its jobs took {results['runtime_s']:.0f} s of compute.")
    verdicts = []
    for s in results["settings"]:
        section.table(_divergence_table(s, conf), f"tbd-{s['ptcr_db']:g}-divergence")
        section.text(_chain_text(s, cfg))
        if s["pairs"] or s.get("chain_vs_filters"):
            section.table(_pairs_table(s, conf), f"tbd-{s['ptcr_db']:g}-pairs")
        section.table(_rmse_table(s, "rmse"), f"tbd-{s['ptcr_db']:g}-rmse")
        section.table(_rmse_table(s, "rmse_all"), f"tbd-{s['ptcr_db']:g}-rmse-all")
        verdicts.append(_verdict(s, cfg))
    for a in results["across_ptcr"]:
        if a["fisher_p"] < ALPHA:
            verdicts.append(f"{a['filter']}: divergence differs between {a['a']:g} and {a['b']:g} dB "
                            f"(Fisher p = {a['fisher_p']:.3f}).")
    verdicts += _chain_verdicts(results["settings"])
    section.text("\n".join(f"* {v}" for v in verdicts))
    if results.get("exit_reentry"):
        for i, table in enumerate(_exit_reentry_tables(results["exit_reentry"], conf)):
            section.table(table, f"tbd-exit-reentry-{i}")
        if text := _exit_reentry_text(results["exit_reentry"]):
            section.text(text)
    return section


def snapshot_png(snap: dict) -> bytes:
    """The study's run 0 at its first PTCR (``tbd_snapshot.json``): a few frames with the first filter's heaviest
    present particles, its estimate and the truth."""
    import matplotlib.pyplot as plt

    from nnda.reports.study_figures import _png

    frames = snap["frames"]
    fig, axes = plt.subplots(1, len(frames), figsize=(3.2 * len(frames), 3.4), squeeze=False)
    for ax, f in zip(axes[0], frames):
        particles, estimate, truth = np.asarray(f["particles"]).reshape(-1, 2), f["estimate"], f["truth"]
        ax.imshow(np.asarray(f["image"]), cmap="gray", interpolation="nearest")
        ax.scatter(particles[:, 1], particles[:, 0], s=4, c="tab:orange", alpha=0.6, linewidths=0, label="particles")
        ax.plot(truth[1], truth[0], "c+", ms=12, mew=2, label="truth")
        ax.plot(estimate[1], estimate[0], "o", mfc="none", mec="tab:red", ms=10, mew=1.5, label="estimate")
        ax.set_title(f"frame {f['frame']}: P(absent) {f['p_absent']:.2f}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    axes[0, 0].legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    return _png(fig)


def in_study_order(results: dict) -> dict:
    """``results`` with the filters and chain trackers of every setting in the study's order (summary.json sorts
    its keys)."""
    cfg = results["config"]
    labels = [f"{f['name']}@{f['particles']}" for f in cfg["filters"]]
    chain = list(cfg["chain"]["trackers"]) if cfg["chain"] else []

    def ordered(s: dict) -> dict:
        return {**s, "filters": {k: s["filters"][k] for k in labels},
                **({"chain": {k: s["chain"][k] for k in chain}} if "chain" in s else {})}

    er = results.get("exit_reentry")
    return {**results, "settings": [ordered(s) for s in results["settings"]],
            "exit_reentry": None if er is None else ordered(er)}


def sections(study: StudyFiles, figures: list[Figure]) -> list[Section]:
    """The TBD study's section of a study report, with the snapshot figure."""
    section = tbd_section(Section("tbd", "Track-before-detect filters", [], []), in_study_order(study.results("tbd")))
    snap = read_json(read_checked(study.out, SNAPSHOT_FILE), SNAPSHOT_FORMAT, SNAPSHOT_VERSION)
    caption = (f"Run 0 at {snap['ptcr_db']:g} dB: frames (gray), the {snap['particles_shown']} heaviest present "
               f"particles of {snap['filter']}, its conditional-mean estimate and the truth")
    figure = Figure("tbd-frames.png", caption, snapshot_png, (snap,))
    figures.append(figure)
    section.figure(figure)
    return [section]
