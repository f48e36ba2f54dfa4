"""No number of a reference work stands under a heading that reads as nnda's: in the README's tables and in the
report tables that set a reference's numbers beside nnda's, a cell that equals a published number sits in a column
(or a row) whose title names the work (author and year) or says "reference" or "published"."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from nnda.reports.claims import Claim
from nnda.reports.pages import StudyFiles
from nnda.reports.pedestrian_section import excess_table, stress_table
from nnda.reports.pedestrian_values import THESIS_EXCESS, THESIS_EXCESS_POINTS, THESIS_RMS, THESIS_RUNTIME_S
from nnda.reports.published_tracking import PUBLISHED_TRACKING
from nnda.reports.reproduction import CLAIMS, claims_table
from nnda.reports.study_tables import scenario_table
from nnda.reports.text_table import TextTable
from nnda.study.measures import TIME, TRACK_MEASURES

ROOT = Path(__file__).resolve().parents[2]
#: a heading that names where a number comes from
NAMED = re.compile(r"\((19|20)\d\d\)|reference|published|Bruno, Araújo & Pavlov", re.I)
#: a column heading that says its numbers are nnda's: no row title can make a reference's number at home there
OURS = re.compile(r"nnda|measured|ours", re.I)


def _published() -> set[str]:
    """The reference works' numbers as the tables print them; only the distinctive ones, with three significant
    digits or more and a fractional part (96.99, 0.243, 55.00): a bare 4 or 0.22 is as likely nnda's own."""
    values = [v for s in PUBLISHED_TRACKING.values() for col in s.values() for v in col.values()]
    values += [v for test in THESIS_RMS.values() for pair in test.values() for v in pair]
    values += [v for test in THESIS_RUNTIME_S.values() for v in test.values()]
    values += [100.0 * v / THESIS_EXCESS_POINTS for f in THESIS_EXCESS.values() for v in f.values()]
    out = set()
    for v in values:
        for fmt in ("{:.2f}", "{:.3f}", "{:g}"):
            text = fmt.format(v)
            if "." in text and len(text.replace(".", "").strip("0")) >= 3:
                out.add(text)
    return out


PUBLISHED = _published()


def _unlabelled(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    """Every cell holding a published number whose column title fails to name its source and whose row title fails
    too, or whose column title says the numbers are nnda's. A cell with an interval (``mean [low, high]``) is a
    mean over nnda's runs: the reference works give single numbers."""
    bad = []
    for row in rows:
        for j, cell in enumerate(row[1:], start=1):
            number = re.match(r"\s*([+-]?\d[\d,]*\.\d+)", cell)
            named = NAMED.search(header[j]) or (NAMED.search(row[0]) and not OURS.search(header[j]))
            if number and number.group(1) in PUBLISHED and not named and "[" not in cell:
                bad.append(f"{cell!r} under {header[j]!r} in row {row[0]!r}")
    return bad


def _markdown_tables(text: str) -> list[tuple[tuple[str, ...], list[tuple[str, ...]]]]:
    tables, lines = [], text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("|") and i + 1 < len(lines) and re.fullmatch(r"\|[\s:|-]+\|?", lines[i + 1].strip()):
            rows, k = [], i + 2
            while k < len(lines) and lines[k].startswith("|"):
                rows.append(tuple(c.strip() for c in lines[k].strip().strip("|").split("|")))
                k += 1
            tables.append((tuple(c.strip() for c in line.strip().strip("|").split("|")), rows))
    return tables


def test_the_checker_finds_a_thesis_number_under_nndas_heading():
    planted = "| | S1 | S2 |\n|---|---|---|\n| Measured by make demo | 96.99 | 93.24 |\n"
    assert len(_unlabelled(*_markdown_tables(planted)[0])) == 2
    named = "| | S1 | S2 |\n|---|---|---|\n| Vargas Avila (2015), one run | 96.99 | 93.24 |\n"
    assert _unlabelled(*_markdown_tables(named)[0]) == []


@pytest.mark.parametrize("page", ["README.md", "docs/guide/reproduce.md", *sorted(
    str(p.relative_to(ROOT)) for p in (ROOT / "docs" / "works").glob("*.md"))])
def test_a_pages_tables_name_the_source_of_every_published_number(page):
    bad = [f"{page}: {b}" for header, rows in _markdown_tables((ROOT / page).read_text(encoding="utf-8"))
           for b in _unlabelled(header, rows)]
    assert bad == []


def _stat(mean: float) -> dict:
    return {"mean": mean, "ci_low": mean - 0.5, "ci_high": mean + 0.5, "n": 3}


def _check(table: TextTable) -> list[str]:
    return _unlabelled(table.header, list(table.rows))


def test_the_scenario_tables_thesis_columns_name_the_thesis():
    metrics = {m.key: _stat(50.0) for m in TRACK_MEASURES}
    scenario = {"name": "S1", "targets": [{}] * 4, "n_scans": 100, "source": "preset S1",
                "trackers": {"mht": {"runs": 3, "metrics": metrics}}}
    table = scenario_table(scenario, {"trackers": {"mht": {TIME.key: _stat(0.005)}}}, True, 0.95)
    assert any("99.63" in row for row in table.rows)     # the thesis's columns are there ...
    assert _check(table) == []                            # ... and named as the thesis's


def test_the_claims_table_puts_every_reference_number_in_its_reference_column():
    study = StudyFiles(Path("/nonexistent"), {}, {"scenarios": []}, {})
    table = claims_table(CLAIMS, {"radar": study})
    assert _check(table) == []
    wrong = claims_table((Claim("Vargas Avila (2015)", "radar", "t", lambda s: _stat(96.99), reference=1.0),),
                         {"radar": StudyFiles(Path("/nonexistent"), {}, {}, {})})
    assert _unlabelled(("Work", "Claim", "Reference", "Measured by nnda", "Verdict", "Reason"),
                       [tuple(wrong.rows[0][:3]) + ("96.99",) + tuple(wrong.rows[0][4:])]) != []


def test_the_pedestrian_tables_name_frencl_2014_and_scale_table_6_5():
    per_run = {"mean": 1.0, "ci_low": -1.0, "ci_high": 3.0, "n": 3}
    filters = {label: {"estimates_per_point": {n: {"per_run": per_run} for n in ("2", "3", ">3")},
                       "true_points": 180} for label in THESIS_EXCESS}
    excess = excess_table({"name": "test4", "accuracy": {"runs": 3, "filters": filters}})
    assert _check(excess) == []
    assert excess.rows[0][1:3] == ("55.00", "1.67 [0.00, 5.00]")    # 19,800 of 36,000; 3 x 1 of 180, cut at 0
    r = {k: _stat(1.0) for k in ("time_per_scan_s", "count_bias", "weight_bias", "count_error", "ospa", "gospa")}
    r["time_per_scan_s"] = {"mean": 0.002, "ci_low": -0.001, "ci_high": 0.005, "n": 2}
    stress = {"runs": 2, "n_scans": 100, "filters": {label: {"per_run": r, "runtime_s": _stat(1.0)}
                                                    for label in THESIS_RUNTIME_S["test2"]}}
    table = stress_table({"name": "test2", "stress_scene": "walk-stress", "stress": stress})
    assert _check(table) == []
    assert table.rows[0][3] == "2.00 [0.00, 5.00]"                  # ms/scan: never below 0
