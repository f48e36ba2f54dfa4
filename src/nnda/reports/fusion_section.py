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
when the intervals do not overlap (and not to fail unless they do). Last, for a single PHD filter on every
sensor (``fusion-central``, ``gmphd``, ``ekphd``, ``ukphd``) that covers fewer undetected target-scans than
a fusion of local filters (``fusion-merge``, ``fusion-aa``) and misses more targets (GOSPA's missed-target
part), the reason, with the filter's own p_D and extraction threshold: a sweep that misses a target
multiplies its weight by 1 - p_D, under the threshold, whichever sensor sweeps; the union keeps the other
sensor's weight. Reads ``study.json`` and ``summary.json``.
"""

from __future__ import annotations

from nnda.reports.claims import HOLDS, NOT_MEASURED, NOT_SHOWN, REVERSED, difference, sign_verdict
from nnda.reports.text_table import TextTable, stat_cell
from nnda.study.measures import measure
from nnda.tracking.registry import TRACKERS

#: the table's measures (registry keys), in column order
COLUMNS = tuple(measure(k) for k in ("gospa", "ospa_localisation", "ospa_cardinality", "count_error",
                                     "time_to_count_s", "tracked_undetected", "false_tracks"))
GOSPA, TIME_TO_COUNT, UNDETECTED = measure("gospa"), measure("time_to_count_s"), measure("tracked_undetected")
MISSED, LOCALISATION = measure("gospa_missed"), measure("gospa_localisation")
#: one PHD filter updated by every sensor's sweeps in turn, and fusions of one local filter per sensor
SINGLE_FILTER_KINDS = ("fusion-central", "gmphd", "ekphd", "ukphd")
UNION_KINDS = ("fusion-merge", "fusion-aa")


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


def detection_and_threshold(spec: dict) -> tuple[float, float] | None:
    """(p_D, extraction threshold) of a PHD tracker's resolved config; None if they differ by sensor."""
    cfg = TRACKERS[spec["kind"]].config_type(**(spec.get("params") or {}))
    return None if cfg.sensor_pd is not None else (cfg.pd, cfg.extraction_threshold)


def single_filter_reasons(manifest: dict, trackers: dict) -> list[str]:
    """For each single PHD filter on every sensor (`SINGLE_FILTER_KINDS`, no ``use_sensors``) of a scene's
    ``trackers`` (summary records by label) that covers fewer undetected target-scans than the scene's first
    union of local filters (`UNION_KINDS`) and has the larger missed-target part of GOSPA: why, from its
    p_D and extraction threshold and those numbers."""
    specs = manifest["study"]["trackers"]
    unions = [label for label in trackers if specs.get(label, {}).get("kind") in UNION_KINDS]
    if not unions:
        return []
    union = trackers[unions[0]]["metrics"]
    lines = []
    for label, rec in trackers.items():
        spec = specs.get(label, {})
        if spec.get("kind") not in SINGLE_FILTER_KINDS or (spec.get("params") or {}).get("use_sensors"):
            continue
        m = rec["metrics"]
        values = [_mean(x[k.key]) for x in (m, union) for k in (UNDETECTED, MISSED, LOCALISATION)]
        if None in values:
            continue
        covered, missed, localised, union_covered, union_missed, union_localised = values
        resolved = detection_and_threshold(spec)
        if resolved is None or not (covered < union_covered and missed > union_missed):
            continue
        pd, threshold = resolved
        lines.append(
            f"- Why {label} (one PHD filter on every sensor's sweeps) trails {unions[0]}: it covers "
            f"{covered:.1f}% of the undetected target-scans against {union_covered:.1f}%, and GOSPA's "
            f"missed-target part is {missed:,.0f} m² against {union_missed:,.0f} m² (localisation "
            f"{localised:,.0f} m² against {union_localised:,.0f} m²). A sweep that misses a target multiplies its "
            f"weight by 1 - p_D = {1 - pd:.2f}, which leaves any weight under {threshold / (1 - pd):.1f} below the "
            f"extraction threshold {threshold:.2f}: the filter drops a target at every sweep of either sensor "
            f"that misses it, and finds it again at the next that detects it. {unions[0]} adds the local "
            f"filters' intensities, about one unit of weight per sensor that holds the target, so one sensor's "
            f"miss leaves the other's weight. This is the PHD update read one scan at a time, not a defect of "
            f"the centralised filter.")
    return lines


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
        section.text("\n".join(lines + single_filter_reasons(manifest, trackers)))
    return section
