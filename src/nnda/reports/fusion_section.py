"""The report's "Fusion against single sensors" section: several sensors against each alone.

Present when a scenario of the study has two or more sensors and the study
runs at least one tracker restricted to a single sensor (a PHD tracker with
``params.use_sensors`` naming one sensor; its other sensors' scans only
predict it). Per such scenario, one row per tracker: the sensors it uses,
GOSPA, the OSPA localisation and cardinality parts, the target-count
error, the time to a correct count, the share of undetected target-scans
(misses, occlusion) a confirmed track still covers and the false tracks,
each ``mean [low, high]`` over runs. Then sentences computed from those
numbers that check the harbour thesis's claims (Lima 2022) for every
tracker using all the sensors against the best single-sensor one: its GOSPA
as a ratio, whether it reaches a correct count sooner ("the fused picture
converges faster") and whether it covers more of the undetected
target-scans ("the occluded ship is recovered"), each said to hold only
when the intervals do not overlap (and not to fail unless they do). Reads ``study.json`` and
``summary.json``.
"""

from __future__ import annotations

from nnda.reports.claims import HOLDS, NOT_MEASURED, NOT_SHOWN, REVERSED, difference, sign_verdict
from nnda.reports.text_table import TextTable, stat_cell
from nnda.study.measures import measure

#: the table's measures (registry keys), in column order
COLUMNS = tuple(measure(k) for k in ("gospa", "ospa_localisation", "ospa_cardinality", "count_error",
                                     "time_to_count_s", "tracked_undetected", "false_tracks"))
GOSPA, TIME_TO_COUNT, UNDETECTED = measure("gospa"), measure("time_to_count_s"), measure("tracked_undetected")


def single_sensor(manifest: dict) -> dict[str, str]:
    """Labels of the study's trackers that use one sensor only -> that sensor's name."""
    found = {}
    for label, spec in manifest["study"]["trackers"].items():
        use = (spec.get("params") or {}).get("use_sensors")
        if use and len(use) == 1:
            found[label] = use[0]
    return found


def _mean(stat: dict | None) -> float | None:
    return None if not stat else stat.get("mean")


def _claim(what: str, mine: dict, theirs: dict, ms, label: str, reference: str) -> str:
    if _mean(mine) is None or _mean(theirs) is None:
        return f"{what}: not measured for {label} or {reference}."
    cells = f"{stat_cell(mine, ms.fmt, ms.scale)} {ms.unit} against {stat_cell(theirs, ms.fmt, ms.scale)} {ms.unit}"
    verdict = {HOLDS: "**holds**", NOT_SHOWN: "not shown (the intervals overlap)",
               REVERSED: "**does not hold** (worse)", NOT_MEASURED: "not shown (too few runs for intervals)",
               }[sign_verdict([difference(mine, theirs)], ms.sense)]
    return f"{what}: {verdict} for {label} ({cells} for {reference})."


def fusion_section(section, manifest: dict, summary: dict):
    """Fill ``section`` (a `nnda.reports.pages.Section`) for every scenario with several sensors and
    single-sensor trackers; None when the study has no such comparison."""
    singles = single_sensor(manifest)
    sensors = {s["name"]: len(s["scenario"].get("sensors", [])) for s in manifest["scenarios"]}
    scenes = [sc for sc in summary["scenarios"] if sensors.get(sc["name"], 1) > 1]
    if not singles or not scenes:
        return None
    section.text("Trackers on every sensor of a scene against trackers restricted to one of them (a PHD "
                 "tracker's `use_sensors`: the other sensors' scans only predict it). Each cell is the mean "
                 "over runs with its 95% interval.")
    for sc in scenes:
        trackers = sc["trackers"]
        rows = []
        for label, rec in trackers.items():
            used = singles.get(label, "all")
            rows.append((label, used, *(stat_cell(rec["metrics"][ms.key], ms.fmt, ms.scale) for ms in COLUMNS)))
        section.table(TextTable(f"{sc['name']}: fusion against single sensors",
                                ("tracker", "sensors", *(ms.title for ms in COLUMNS)), tuple(rows)),
                      f"fusion-{sc['name']}")
        alone = {label: trackers[label] for label in singles if label in trackers}
        scored = {label: _mean(rec["metrics"][GOSPA.key]) for label, rec in alone.items()}
        scored = {label: g for label, g in scored.items() if g is not None}
        if not scored:
            continue
        best = min(scored, key=scored.__getitem__)
        lines = [f"Against the best single-sensor tracker of {sc['name']}, **{best}** "
                 f"(GOSPA {scored[best]:.1f} m):"]
        for label, rec in trackers.items():
            if label in singles:
                continue
            g = _mean(rec["metrics"][GOSPA.key])
            ratio = f"GOSPA {g / scored[best]:.2f}x the best single sensor's" if g else "GOSPA not measured"
            lines.append(f"- {label}: {ratio}. "
                         + _claim("Faster to a correct count", rec["metrics"][TIME_TO_COUNT.key],
                                  trackers[best]["metrics"][TIME_TO_COUNT.key], TIME_TO_COUNT, label, best) + " "
                         + _claim("More undetected target-scans covered (misses, occlusion)",
                                  rec["metrics"][UNDETECTED.key], trackers[best]["metrics"][UNDETECTED.key],
                                  UNDETECTED, label, best))
        section.text("\n".join(lines))
    return section
