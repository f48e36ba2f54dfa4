"""The report of ``nnda reproduce``: each reference work's claims, nnda's numbers with intervals, the verdicts.

    write_reproduction(out, {"radar": out / "radar", ...}, "quick")   # out/report.md, out/report.html

`CLAIMS` holds what the five reference works claim that nnda's studies
measure, each a `nnda.reports.claims.Claim` naming the study directory it
reads (``radar``, ``harbour``, ``pedestrian``, ``reentry``, ``tbd``):

* Vargas Avila (2015), the radar thesis (S1-S6): the hit rates of its
  IMM/TOMHT and of its neural association and their confirmed tracks
  (Tables 6.4-6.9), the targets its MHT lost in the gap scenarios, and that
  the neural tracker is faster;
* Lima (2022) and Lima & Costa (2022), the two-radar harbour: the fused
  picture (union and merge of the local GM-PHDs) against each radar alone;
* Frencl (2014), the pedestrian tests: the mean RMS of Tables 6.1 and 6.3
  and the thesis's conclusions on its filters and motion models;
* Pavlov & Bruno (2003), the ballistic re-entry: the optimal importance
  function against the bootstrap filter at the same particle count;
* Bruno, Araújo & Pavlov, track-before-detect: the divergent runs of the
  auxiliary particle filter and of resample-move.

The page's first table is those claims; the studies follow, each with a
link to its own report. A claim the studies do not measure (a study left
out, a size too small for an interval) reads *not measured*.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable, Mapping
from pathlib import Path

from nnda.models.metrics import PUBLISHED_TABLE_6_3
from nnda.reports.claims import AGREES, HOLDS, NOT_MEASURED, REVERSED, Claim, Stat, difference, number_verdict
from nnda.reports.fusion_section import detection_and_threshold
from nnda.reports.pages import Section, StudyFiles, write_pages
from nnda.reports.pedestrian_section import comparisons, in_study_order
from nnda.reports.pedestrian_values import THESIS_RMS
from nnda.reports.published_tracking import PUBLISHED_TRACKING
from nnda.reports.reentry_section import AGREEMENT_PARTICLES, largest_gap
from nnda.reports.study_report import study_files
from nnda.reports.text_table import TextTable
from nnda.study.stats import clopper_pearson
from nnda.study.tbd import PAPER_DIVERGENCES

RADAR, HARBOUR, PEDESTRIAN = "Vargas Avila (2015)", "Lima (2022); Lima & Costa (2022)", "Frencl (2014)"
REENTRY, TBD = "Pavlov & Bruno (2003)", "Bruno, Araújo & Pavlov"
UNDEFINED: Stat = {"mean": None, "ci_low": None, "ci_high": None}


def _scenario(study: StudyFiles, name: str) -> dict:
    return next(s for s in study.summary["scenarios"] if s["name"] == name)


def _metric(scenario: str, tracker: str, key: str) -> Callable[[StudyFiles], Stat]:
    return lambda study: _scenario(study, scenario)["trackers"][tracker]["metrics"][key]


def _time(study: StudyFiles, scenario: str, tracker: str) -> Stat:
    times = next(s for s in study.timing["scenarios"] if s["name"] == scenario)["trackers"][tracker]
    return times["mean_time_per_scan_s"]


SCENES = tuple(f"S{i}" for i in range(1, 7))
MHT, NEURAL, OURS = "mht", "nn-seed", "nn-life"


def _mean(study: StudyFiles, scene: str, tracker: str, key: str) -> float:
    return _metric(scene, tracker, key)(study)["mean"]


def _span(values: list[float], fmt: str = "{:.1f}") -> str:
    low, high = fmt.format(min(values)), fmt.format(max(values))
    return low if low == high else f"{low}-{high}"


def _mht_lost_reason(scene: str) -> Callable[[StudyFiles], str]:
    def reason(study: StudyFiles) -> str:
        lost = _mean(study, scene, MHT, "lost_targets")
        return (f"nnda's MHT loses {lost:.1f} targets a run where Vargas Avila (2015)'s lost 2"
                + (": a stronger baseline." if lost < 2 else "."))
    return reason


def _mht_tracks_reason(scene: str) -> Callable[[StudyFiles], str]:
    def reason(study: StudyFiles) -> str:
        n, targets = _mean(study, scene, MHT, "confirmed_tracks"), len(_scenario(study, scene)["targets"])
        thesis = PUBLISHED_TRACKING[scene]["classical"]["confirmed_tracks"]
        return (f"nnda's MHT confirms {n:.1f} tracks a run for {targets} targets where Vargas Avila (2015)'s "
                f"confirmed {thesis:.0f}" + (": fewer false tracks." if n < thesis else "."))
    return reason


def _versus(scenes: tuple[str, ...], key: str, noun: str, fmt: str) -> Callable[[StudyFiles], str]:
    """The reason of a neural-against-MHT comparison: nnda's two means beside the thesis's (`PUBLISHED_TRACKING`),
    and whether nnda's MHT is the stronger or weaker baseline of the two."""
    better = {"lost_targets": -1, "confirmed_tracks": -1, "hit_rate": +1}[key]

    def reason(study: StudyFiles) -> str:
        nn = [_mean(study, s, NEURAL, key) for s in scenes]
        mht = [_mean(study, s, MHT, key) for s in scenes]
        thesis = [(PUBLISHED_TRACKING[s]["proposed"][key], PUBLISHED_TRACKING[s]["classical"][key]) for s in scenes]
        mht_gain = sum(better * (m - t[1]) for m, t in zip(mht, thesis, strict=True))
        nn_gain = sum(better * (n - t[0]) for n, t in zip(nn, thesis, strict=True))
        where = "" if len(scenes) == 1 else f" ({scenes[0]}-{scenes[-1]})"
        baseline = "a stronger baseline than" if mht_gain > 0 else "a weaker baseline than" if mht_gain < 0 else \
            "as strong a baseline as"
        tracker = "a better tracker than" if nn_gain > 0 else "a worse tracker than" if nn_gain < 0 else \
            "as good a tracker as"
        return (f"{noun}{where}: nnda's neural association {_span(nn, fmt)} against its MHT's {_span(mht, fmt)}; "
                f"Vargas Avila (2015)'s {_span([t[0] for t in thesis], fmt)} against "
                f"{_span([t[1] for t in thesis], fmt)}: nnda's MHT is {baseline} the thesis's, and nnda's neural "
                f"association {tracker} the thesis's.")
    return reason


def _comparisons() -> list[Claim]:
    """The thesis's comparison itself, neural association against its IMM/TOMHT (Section 6.3, Tables 6.4-6.9):
    each a sign claim on nnda's differences, neural less MHT."""
    def versus(key: str, among: tuple[str, ...]) -> Callable[[StudyFiles], list[Stat]]:
        return lambda study: [difference(_metric(s, NEURAL, key)(study), _metric(s, MHT, key)(study)) for s in among]

    lost = [Claim(RADAR, "radar", f"{s}: the neural association loses fewer targets than IMM/TOMHT (the thesis: "
                  "none against two; neural less MHT)", versus("lost_targets", (s,)), sign=-1, fmt="{:+.1f}",
                  reason=_versus((s,), "lost_targets", "lost targets a run", "{:.1f}")) for s in ("S3", "S5")]
    return [*lost,
            Claim(RADAR, "radar", "S4-S6: the neural association's hit rate is above IMM/TOMHT's (Tables 6.7-6.9; "
                                  "neural less MHT)", versus("hit_rate", ("S4", "S5", "S6")), sign=+1, unit="points",
                  fmt="{:+.2f}", reason=_versus(("S4", "S5", "S6"), "hit_rate", "hit rate %", "{:.2f}")),
            Claim(RADAR, "radar", "the neural association confirms fewer tracks than IMM/TOMHT (S1-S6; neural less "
                                  "MHT)", versus("confirmed_tracks", SCENES), sign=-1, fmt="{:+.1f}",
                  reason=_versus(SCENES, "confirmed_tracks", "confirmed tracks a run", "{:.1f}"))]


def _radar() -> list[Claim]:
    scenes = list(SCENES)
    claims = []
    for column, label, name in (("classical", MHT, "IMM/TOMHT"), ("proposed", NEURAL, "neural association")):
        claims += [Claim(RADAR, "radar", f"{s}: {name}'s hit rate", _metric(s, label, "hit_rate"),
                         reference=PUBLISHED_TRACKING[s][column]["hit_rate"], unit="%") for s in scenes]
    claims += [Claim(RADAR, "radar", f"{s}: IMM/TOMHT loses two targets in the detection gaps",
                     _metric(s, MHT, "lost_targets"), reference=2.0, fmt="{:.1f}", reason=_mht_lost_reason(s))
               for s in ("S3", "S5")]
    for column, label, name in (("classical", MHT, "IMM/TOMHT"), ("proposed", NEURAL, "neural association")):
        claims += [Claim(RADAR, "radar", f"{s}: {name}'s confirmed tracks", _metric(s, label, "confirmed_tracks"),
                         reference=PUBLISHED_TRACKING[s][column]["confirmed_tracks"], fmt="{:.1f}",
                         reason=_mht_tracks_reason(s) if label == MHT else None) for s in scenes]

    claims += _comparisons()
    claims.append(Claim(RADAR, "radar", "the neural association is faster per scan than IMM/TOMHT (S1-S6)",
                        lambda study: [difference(_time(study, s, NEURAL), _time(study, s, MHT)) for s in scenes],
                        sign=-1, unit="ms", fmt="{:+.2f}", scale=1e3))
    return claims


#: the harbour study's principled fusions: one GM-PHD updated by both radars, GCI of the two local intensities
SOUND_FUSIONS = ("fusion-central", "fusion-gci")


def _harbour() -> list[Claim]:
    fused, singles = "fusion-merge", ("radar1", "radar2")

    def against(scene: str, key: str) -> Callable[[StudyFiles], list[Stat]]:
        def measured(study: StudyFiles) -> list[Stat]:
            trackers = _scenario(study, scene)["trackers"]
            return [difference(trackers[fused]["metrics"][key], trackers[r]["metrics"][key]) for r in singles]
        return measured

    def sound(scene: str) -> Callable[[StudyFiles], list[Stat]]:
        def measured(study: StudyFiles) -> list[Stat]:
            trackers = _scenario(study, scene)["trackers"]
            return [difference(trackers[r]["metrics"]["tracked_undetected"],
                               trackers[fused]["metrics"]["tracked_undetected"]) for r in SOUND_FUSIONS]
        return measured

    def why(scene: str) -> Callable[[StudyFiles], str]:
        def reason(study: StudyFiles) -> str:
            trackers = _scenario(study, scene)["trackers"]
            covered = {r: trackers[r]["metrics"]["tracked_undetected"]["mean"] for r in (*SOUND_FUSIONS, fused)}
            pd, threshold = detection_and_threshold(study.manifest["study"]["trackers"][SOUND_FUSIONS[0]])
            return (f"undetected ship-scans covered: {', '.join(f'{r} {v:.1f} %' for r, v in covered.items())}. "
                    f"In one PHD filter a sweep that misses a ship multiplies its weight by 1 - p_D = {1 - pd:.2f}, "
                    f"under the extraction threshold {threshold:.2f}, at every miss of either radar; GCI's geometric "
                    "mean keeps only what both local intensities hold, so it loses what one radar cannot see; the "
                    "merge adds the two local weights, so one radar's miss leaves the other's.")
        return reason

    return [c for scene in ("harbour", "harbour-dense") for c in (
        Claim(HARBOUR, "harbour", f"{scene}: the sound fusions beat the union-and-merge baseline: a single GM-PHD on "
                                  "both radars and GCI fusion keep more undetected ship-scans than the merge (what "
                                  "the literature expects; Lima (2022) compares neither)", sound(scene), sign=+1,
              unit="%", fmt="{:+.1f}", reason=why(scene)),
        Claim(HARBOUR, "harbour", f"{scene}: the fused picture reaches a correct target count sooner than either "
                                  "radar", against(scene, "time_to_count_s"), sign=-1, unit="s", fmt="{:+.1f}"),
        Claim(HARBOUR, "harbour", f"{scene}: the fused picture has a lower OSPA than either radar",
              against(scene, "ospa"), sign=-1, unit="m", fmt="{:+.1f}"),
        Claim(HARBOUR, "harbour", f"{scene}: the fused picture keeps the target a radar loses (more undetected "
                                  "target-scans covered than either radar)", against(scene, "tracked_undetected"),
              sign=+1, unit="%", fmt="{:+.1f}"))]


def _test(study: StudyFiles, name: str) -> dict:
    return next(t for t in in_study_order(study.results("pedestrian"))["tests"] if t["name"] == name)


#: the thesis's conclusions per test and the sign of the differences that decide each, in the order
#: `nnda.reports.pedestrian_section.comparisons` gives them
PEDESTRIAN_CONCLUSIONS = {
    "test2": (("EK-PHD + NCSHT is the most accurate filter", -1), ("UK-PHD is clearly worse than EK-PHD", +1),
              ("GM-PHD + CV runs faster than EK-PHD + NCSHT", -1), ("every filter overestimates the target count", +1)),
    "test3": (("the HM-map model gives the most precise estimates", -1), ("modified NCSHT beats CV", -1)),
    "test4": (("the HM map gives fewer duplicate estimates", -1),
              ("the HM map narrows the scatter across the corridor", -1)),
}


def _pedestrian() -> list[Claim]:
    claims = []
    for test, filters in THESIS_RMS.items():
        for label, values in filters.items():
            claims += [Claim(PEDESTRIAN, "pedestrian", f"{test}: {label}'s mean RMS_{axis}",
                             lambda study, t=test, f=label, a=axis: _test(study, t)["accuracy"]["filters"][f]
                             ["mean_rms"][a], reference=value, unit="m", fmt="{:.3f}")
                       for axis, value in zip(("x", "y"), values)]
    for test, conclusions in PEDESTRIAN_CONCLUSIONS.items():
        for i, (text, sign) in enumerate(conclusions):
            claims.append(Claim(PEDESTRIAN, "pedestrian", f"{test}: {text}",
                                lambda study, t=test, i=i: comparisons(_test(study, t))[i][1], sign=sign,
                                fmt="{:+.3f}"))
    return claims


def _reentry_pair(study: StudyFiles, setting: str, n: int) -> tuple[dict, dict]:
    """The bootstrap-against-optimal comparison at ``n`` particles of re-entry setting ``setting``, and the
    setting's filters."""
    s = next(s for s in study.results("reentry")["settings"] if s["name"] == setting)
    return next(c for c in s["comparisons"] if (c["a"], c["b"]) == (f"bootstrap@{n}", f"optimal@{n}")), s["filters"]


def _large_n_reason(study: StudyFiles) -> str:
    c, filters = _reentry_pair(study, "sweep", AGREEMENT_PARTICLES)
    a, b, i, total, rest = largest_gap(c, filters)
    return (f"run {i} (from 0) carries {a[i] - b[i]:+.0f} m of the {total:+.0f} m summed per-run difference; without "
            f"it the mean difference is {rest:+.1f} m, and the optimal filter is better on {c['b_better']:.0%} of "
            f"runs (sign test p = {c['sign_test_p']:.2g}).")


def _reentry() -> list[Claim]:
    def optimal_gain(setting: str, n: int) -> Callable[[StudyFiles], Stat]:
        return lambda study: _reentry_pair(study, setting, n)[0]["difference"]

    return [Claim(REENTRY, "reentry", "the optimal importance function beats the bootstrap filter at the same "
                                      "particle count (the paper's sensor, 4,000 particles: per-run position error, "
                                      "bootstrap less optimal)", optimal_gain("paper", 4000), sign=+1, unit="m",
                  fmt="{:+.1f}"),
            Claim(REENTRY, "reentry", "the same on a precise sensor (5 m, 0.5 mrad; 1,000 particles)",
                  optimal_gain("precise", 1000), sign=+1, unit="m", fmt="{:+.1f}"),
            Claim(REENTRY, "reentry", f"at {AGREEMENT_PARTICLES:,d} particles the two filters agree, both estimating "
                                      "the same posterior mean (bootstrap over optimal position error: 1)",
                  lambda study: _reentry_pair(study, "sweep", AGREEMENT_PARTICLES)[0]["ratio"], reference=1.0,
                  fmt="{:.3f}", reason=_large_n_reason)]


def _divergence(ptcr: float, label: str) -> Callable[[StudyFiles], Stat]:
    def measured(study: StudyFiles) -> Stat:
        s = next(s for s in study.results("tbd")["settings"] if s["ptcr_db"] == ptcr)
        d = s["filters"][label]["divergence"]
        return {"mean": d["rate"], "ci_low": d["ci_low"], "ci_high": d["ci_high"]}
    return measured


def _exit_reentry(study: StudyFiles, label: str) -> dict:
    return study.results("tbd")["exit_reentry"]["filters"][label]


def _false_presence(label: str) -> Callable[[StudyFiles], Stat]:
    """The share of the exit/re-entry demonstration's target-free frames that ``label`` declares present, with a
    Clopper-Pearson interval over those frames."""
    def measured(study: StudyFiles) -> Stat:
        f = _exit_reentry(study, label)
        n = f["absent_frames"]
        count = round(f["false_detection_rate"] * n)
        low, high = clopper_pearson(count, n, study.results("tbd")["config"]["confidence"])
        return {"mean": count / n, "ci_low": low, "ci_high": high}
    return measured


def _presence_reason(label: str) -> Callable[[StudyFiles], str]:
    def reason(study: StudyFiles) -> str:
        f = _exit_reentry(study, label)
        again = f["reacquire"]
        return (f"{label} declares {round(f['false_detection_rate'] * f['absent_frames'])} of {f['absent_frames']} "
                f"target-free frames present and never reacquires {again['never']} of {again['events']} re-entries; "
                f"it declares {f['detection_rate']:.0%} of the target's frames present.")
    return reason


def _tbd() -> list[Claim]:
    claims = []
    for ptcr, counts in PAPER_DIVERGENCES.items():
        for name, label in (("apf", "apf@5000"), ("rs", "rs@8000")):
            claims.append(Claim(TBD, "tbd", f"{ptcr:g} dB: {label}'s divergent runs ({counts[name]}/100)",
                                _divergence(ptcr, label), reference=counts[name] / 100, unit="%", fmt="{:.1f}",
                                scale=100.0))
        claims.append(Claim(TBD, "tbd", f"{ptcr:g} dB: the auxiliary filter diverges less than resample-move",
                            lambda study, p=ptcr: difference(_divergence(p, "apf@5000")(study),
                                                             _divergence(p, "rs@8000")(study)),
                            sign=-1, unit="points", fmt="{:+.1f}", scale=100.0))
    claims.append(Claim(TBD, "tbd", "exit and re-entry: the auxiliary filter declares no target-free frame present "
                                    "(share of target-free frames declared present)", _false_presence("apf@5000"),
                        reference=0.0, unit="%", fmt="{:.1f}", scale=100.0, reason=_presence_reason("apf@5000")))
    return claims


#: every claim the reproduction checks, in report order
CLAIMS: tuple[Claim, ...] = (*_radar(), *_harbour(), *_pedestrian(), *_reentry(), *_tbd())


def _measured(claim: Claim, study: StudyFiles | None) -> tuple[str, str, str]:
    """nnda's cell, the verdict of ``claim`` on ``study`` (None: not run) and its reason; a study that lacks the
    entry the claim reads (a test left out, a filter not run) does not measure it."""
    if study is None:
        return "-", NOT_MEASURED, "the study was not run."
    try:
        return claim.nnda_cell(study), claim.verdict(study), claim.reason_text(study)
    except (KeyError, IndexError, StopIteration):
        return "-", NOT_MEASURED, "the study's results lack the entry this claim reads."


def claims_table(claims: tuple[Claim, ...], studies: Mapping[str, StudyFiles]) -> TextTable:
    """The reproduction's first table: reference work, claim, the reference's number, nnda's, the verdict and
    its reason."""
    rows = []
    for claim in claims:
        cell, verdict, reason = _measured(claim, studies.get(claim.study))
        rows.append((claim.work, claim.text, claim.reference_cell(), cell, f"**{verdict}**", reason))
    return TextTable("The reference works' claims against nnda", ("Reference work", "Claim", "Reference",
                                                                   "nnda [95% interval]", "Verdict", "Reason"),
                     tuple(rows),
                     "A number agrees when the reference's value lies in nnda's interval (nnda higher / lower when "
                     "the whole interval lies on one side). A comparison holds when every difference's interval lies "
                     "on the claimed side of 0 ('lower': the claim says nnda's difference is below 0), is reversed "
                     "when one lies wholly on the other side, and is not shown when an interval holds 0.")


def _classifier(study: StudyFiles) -> dict[str, dict]:
    """The radar study's trained networks by label (``classifier.json``), or {} when it has none."""
    try:
        models = json.loads((study.out / "classifier.json").read_text(encoding="utf-8"))["models"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    return {m["label"]: m for m in models if isinstance(m, dict) and "label" in m}


def radar_reading(study: StudyFiles) -> str:
    """The plain reading of the radar study against Vargas Avila (2015): nnda's MHT is a much stronger baseline
    than the thesis's, the thesis's own method does not hold up against it, and what it takes (``nn-life``) to get
    there; every number is the study's, every one of the thesis's named as the thesis's."""
    def means(tracker: str, key: str) -> list[float]:
        return [_mean(study, s, tracker, key) for s in SCENES]

    targets = [len(_scenario(study, s)["targets"]) for s in SCENES]
    thesis_tracks = [PUBLISHED_TRACKING[s]["classical"]["confirmed_tracks"] for s in SCENES]
    outside = [s for s in SCENES
               if number_verdict(PUBLISHED_TRACKING[s]["proposed"]["hit_rate"],
                                 _metric(s, NEURAL, "hit_rate")(study)) != AGREES]
    compared = [c.verdict(study) for c in _comparisons()]
    stronger = all(_mean(study, s, MHT, "lost_targets") < 2 for s in ("S3", "S5")) and all(
        _mean(study, s, MHT, "confirmed_tracks") < PUBLISHED_TRACKING[s]["classical"]["confirmed_tracks"]
        for s in SCENES)
    verdict = ("does not hold in nnda" if REVERSED in compared else "holds in nnda" if set(compared) == {HOLDS}
               else "is not shown in nnda either way")
    text = (f"**The thesis's comparison {verdict}** ({', '.join(compared)}). nnda's IMM/TOMHT is "
            f"{'a much stronger' if stronger else 'not a stronger'} baseline than the thesis's: it confirms "
            f"{_span(means(MHT, 'confirmed_tracks'))} tracks a run on scenes of {_span(targets, '{:.0f}')} "
            f"targets and loses {_span(means(MHT, 'lost_targets'))} targets a run, where Vargas Avila (2015)'s MHT "
            f"confirmed {_span(thesis_tracks, '{:.0f}')} tracks and lost 2 targets in each of S3 and S5. Against it "
            f"the thesis's method "
            f"(`{NEURAL}`: three kinematic features, Levenberg-Marquardt) "
            f"{'does not hold up' if REVERSED in compared else 'holds up'}: it confirms "
            f"{_span(means(NEURAL, 'confirmed_tracks'))} tracks a run, loses {_span(means(NEURAL, 'lost_targets'))} "
            f"targets a run (the thesis's neural tracker lost none), and the thesis's neural hit rate lies outside "
            f"nnda's interval in {len(outside)} of {len(SCENES)} scenarios ({', '.join(outside) or 'none'}). ")
    trackers = _scenario(study, SCENES[0])["trackers"]
    if OURS in trackers:
        text += (f"What it takes to match the MHT is `{OURS}`: the IMM-extended features and nnda's rules for "
                 f"coasting and young tracks. It loses {_span(means(OURS, 'lost_targets'))} targets a run, confirms "
                 f"{_span(means(OURS, 'confirmed_tracks'))} tracks and hits {_span(means(OURS, 'hit_rate'), '{:.2f}')} "
                 f"% of the target contacts against the MHT's {_span(means(MHT, 'hit_rate'), '{:.2f}')} %. ")
    nets = _classifier(study)
    if "gd" in nets and "lm" in nets:
        acc = {k: nets[k]["evaluation"]["metrics"]["accuracy"] for k in ("gd", "lm")}
        gd = nets["gd"]
        stopped = (f"; nnda's gradient descent stopped at its {gd['epochs']:,d}-epoch limit with its best epoch the "
                   f"last, still improving" if gd.get("stop_reason") == "max_epochs"
                   and gd.get("best_epoch") == gd.get("epochs") else "")
        text += (f"The networks classify {acc['gd']:.3f} (gradient descent) and {acc['lm']:.3f} "
                 f"(Levenberg-Marquardt) of their training pairs, where Vargas Avila (2015) reports "
                 f"{PUBLISHED_TABLE_6_3['gd']['accuracy']:.3f} and {PUBLISHED_TABLE_6_3['lm']['accuracy']:.3f}"
                 f"{stopped}. The thesis's figures need an error-free track history (`nnda train --history true`), "
                 f"which the tracker never has.")
    return text


def write_reproduction(out: Path, dirs: Mapping[str, Path], size: str, claims: tuple[Claim, ...] = CLAIMS) -> Path:
    """Write ``out``/report.md and report.html: the claims table over the study directories ``dirs`` (by study
    name, in the order the page lists them), a tally of the verdicts, then each study with a link to its own
    report."""
    studies = {name: study_files(path) for name, path in dirs.items()}
    top = Section("claims", "Claims of the reference works", [], [])
    table = claims_table(claims, studies)
    top.table(table, "claims")
    tally = Counter(row[4].strip("*") for row in table.rows)
    top.text(f"{len(table.rows)} claims at the {size} size: " + ", ".join(f"{n} {v}" for v, n in tally.most_common())
             + ". Each study's own report gives its tables, figures and the reading of every number.")
    if "radar" in studies:
        try:
            top.text(radar_reading(studies["radar"]))
        except (KeyError, IndexError, StopIteration, TypeError):  # a radar study without S1-S6 or these trackers
            pass
    listing = Section("studies", "The studies", [], [])
    lines = []
    for name, st in studies.items():
        ex = st.timing["execution"]
        lines.append(f"* **{name}**: {st.manifest['study']['description']} ({st.manifest['jobs']} jobs, "
                     f"{ex['seconds']:.0f} s on {ex['executor']}); [its report]({name}/report.html)")
    listing.text("\n".join(lines))
    return write_pages(out, f"nnda reproduce ({size}): the reference works against nnda", [top, listing])
