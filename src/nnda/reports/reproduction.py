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

from collections import Counter
from collections.abc import Callable, Mapping
from pathlib import Path

from nnda.reports.claims import Claim, Stat, difference
from nnda.reports.pages import Section, StudyFiles, write_pages
from nnda.reports.pedestrian_section import comparisons, in_study_order
from nnda.reports.pedestrian_values import THESIS_RMS
from nnda.reports.published_tracking import PUBLISHED_TRACKING
from nnda.reports.study_report import study_files
from nnda.reports.text_table import TextTable
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


def _radar() -> list[Claim]:
    scenes = [f"S{i}" for i in range(1, 7)]
    claims = []
    for column, label, name in (("classical", "mht", "IMM/TOMHT"), ("proposed", "nn-seed", "neural association")):
        claims += [Claim(RADAR, "radar", f"{s}: {name}'s hit rate", _metric(s, label, "hit_rate"),
                         reference=PUBLISHED_TRACKING[s][column]["hit_rate"], unit="%") for s in scenes]
    claims += [Claim(RADAR, "radar", f"{s}: IMM/TOMHT loses two targets in the detection gaps",
                     _metric(s, "mht", "lost_targets"), reference=2.0, fmt="{:.1f}") for s in ("S3", "S5")]
    for column, label, name in (("classical", "mht", "IMM/TOMHT"), ("proposed", "nn-seed", "neural association")):
        claims += [Claim(RADAR, "radar", f"{s}: {name}'s confirmed tracks", _metric(s, label, "confirmed_tracks"),
                         reference=PUBLISHED_TRACKING[s][column]["confirmed_tracks"], fmt="{:.1f}") for s in scenes]
    claims.append(Claim(RADAR, "radar", "the neural association is faster per scan than IMM/TOMHT (S1-S6)",
                        lambda study: [difference(_time(study, s, "nn-seed"), _time(study, s, "mht")) for s in scenes],
                        sign=-1, unit="ms", fmt="{:+.2f}", scale=1e3))
    return claims


def _harbour() -> list[Claim]:
    fused, singles = "fusion-merge", ("radar1", "radar2")

    def against(scene: str, key: str) -> Callable[[StudyFiles], list[Stat]]:
        def measured(study: StudyFiles) -> list[Stat]:
            trackers = _scenario(study, scene)["trackers"]
            return [difference(trackers[fused]["metrics"][key], trackers[r]["metrics"][key]) for r in singles]
        return measured

    return [c for scene in ("harbour", "harbour-dense") for c in (
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


def _reentry() -> list[Claim]:
    def optimal_gain(setting: str, n: int) -> Callable[[StudyFiles], Stat]:
        def measured(study: StudyFiles) -> Stat:
            s = next(s for s in study.results("reentry")["settings"] if s["name"] == setting)
            return next(c for c in s["comparisons"] if (c["a"], c["b"]) == (f"bootstrap@{n}", f"optimal@{n}")
                        )["difference"]
        return measured

    return [Claim(REENTRY, "reentry", "the optimal importance function beats the bootstrap filter at the same "
                                      "particle count (the paper's sensor, 4,000 particles: per-run position error, "
                                      "bootstrap less optimal)", optimal_gain("paper", 4000), sign=+1, unit="m",
                  fmt="{:+.1f}"),
            Claim(REENTRY, "reentry", "the same on a precise sensor (5 m, 0.5 mrad; 1,000 particles)",
                  optimal_gain("precise", 1000), sign=+1, unit="m", fmt="{:+.1f}")]


def _divergence(ptcr: float, label: str) -> Callable[[StudyFiles], Stat]:
    def measured(study: StudyFiles) -> Stat:
        s = next(s for s in study.results("tbd")["settings"] if s["ptcr_db"] == ptcr)
        d = s["filters"][label]["divergence"]
        return {"mean": d["rate"], "ci_low": d["ci_low"], "ci_high": d["ci_high"]}
    return measured


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
    return claims


#: every claim the reproduction checks, in report order
CLAIMS: tuple[Claim, ...] = (*_radar(), *_harbour(), *_pedestrian(), *_reentry(), *_tbd())


def _measured(claim: Claim, study: StudyFiles | None) -> tuple[str, str]:
    """nnda's cell and the verdict of ``claim`` on ``study`` (None: not run); a study that lacks the entry the
    claim reads (a test left out, a filter not run) does not measure it."""
    if study is None:
        return "-", "not measured"
    try:
        return claim.nnda_cell(study), claim.verdict(study)
    except (KeyError, IndexError, StopIteration):
        return "-", "not measured"


def claims_table(claims: tuple[Claim, ...], studies: Mapping[str, StudyFiles]) -> TextTable:
    """The reproduction's first table: reference work, claim, the reference's number, nnda's, the verdict."""
    rows = []
    for claim in claims:
        cell, verdict = _measured(claim, studies.get(claim.study))
        rows.append((claim.work, claim.text, claim.reference_cell(), cell, f"**{verdict}**"))
    return TextTable("The reference works' claims against nnda", ("Reference work", "Claim", "Reference",
                                                                   "nnda [95% interval]", "Verdict"), tuple(rows),
                     "A number agrees when the reference's value lies in nnda's interval (nnda higher / lower when "
                     "the whole interval lies on one side). A comparison holds when every difference's interval lies "
                     "on the claimed side of 0 ('lower': the claim says nnda's difference is below 0), is reversed "
                     "when one lies wholly on the other side, and is not shown when an interval holds 0.")


def write_reproduction(out: Path, dirs: Mapping[str, Path], size: str, claims: tuple[Claim, ...] = CLAIMS) -> Path:
    """Write ``out``/report.md and report.html: the claims table over the study directories ``dirs`` (by study
    name, in the order the page lists them), a tally of the verdicts, then each study with a link to its own
    report."""
    studies = {name: study_files(path) for name, path in dirs.items()}
    top = Section("claims", "Claims of the reference works", [], [])
    table = claims_table(claims, studies)
    top.table(table, "claims")
    tally = Counter(row[-1].strip("*") for row in table.rows)
    top.text(f"{len(table.rows)} claims at the {size} size: " + ", ".join(f"{n} {v}" for v, n in tally.most_common())
             + ". Each study's own report gives its tables, figures and the reading of every number.")
    listing = Section("studies", "The studies", [], [])
    lines = []
    for name, st in studies.items():
        ex = st.timing["execution"]
        lines.append(f"* **{name}**: {st.manifest['study']['description']} ({st.manifest['jobs']} jobs, "
                     f"{ex['seconds']:.0f} s on {ex['executor']}); [its report]({name}/report.html)")
    listing.text("\n".join(lines))
    return write_pages(out, f"nnda reproduce ({size}): the reference works against nnda", [top, listing])
