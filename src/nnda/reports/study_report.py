"""The report of a study directory: ``report.md`` with ``figures/*.png`` and a self-contained ``report.html``.

    write_report("out/harbour")      # every kind the study ran, its sections in registry order

Built only from what the study wrote (``study.json``, then the files
checked against ``checksums.json``), so ``nnda report DIR`` rebuilds it at
any time. Every Parquet table ``checksums.json`` lists (and the directory
holds) is opened first, so a damaged one is an error naming it before any
section reads it. Each job kind the study ran (``study.json``'s ``kinds``)
adds its sections through `SECTIONS`; a kind with no entry there gets
`summary_sections`, a table of every number of its ``summary.json`` entry,
so a new kind is reported from its first run. The HTML page inlines
plotly.js when a section draws an interactive figure.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from nnda.errors import DatasetError
from nnda.files import read_json
from nnda.reports import pedestrian_section, reentry_section, tbd_section
from nnda.reports.pages import Figure, Section, StudyFiles, html_page, markdown_page, render, write_pages
from nnda.reports.text_table import TextTable
from nnda.reports.track_report import track_sections
from nnda.reports.trajectory_plot import plotly_js
from nnda.study.checksums import listed, read_schema
from nnda.study.plan import STUDY_FORMAT, STUDY_FORMAT_VERSION
from nnda.study.results import read_summary
from nnda.study.runner import MANIFEST

#: the sections of each job kind: a function of the study's files that returns its sections (figures, when it
#: draws any, appended to the list it is given); the filter kind's stand among the tracker kind's
SECTIONS: dict[str, Callable[[StudyFiles, list[Figure]], list[Section]]] = {
    "track": track_sections,
    "filter": lambda study, figures: [],
    "reentry": reentry_section.sections,
    "tbd": tbd_section.sections,
    "pedestrian": pedestrian_section.sections,
}
#: the kinds whose sections draw plotly figures (the page then inlines plotly.js)
INTERACTIVE = {"track"}


def _numbers(value, path: str = ""):
    """(path, number) of every number inside a summary entry, depth first."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _numbers(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _numbers(v, f"{path}[{i}]")
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path, value


def summary_sections(kind: str, study: StudyFiles) -> list[Section]:
    """A kind without sections of its own: every number of its ``summary.json`` and ``timing.json`` entries."""
    sec = Section(f"kind-{kind}", f"{kind} jobs", [], [])
    sec.text(f"The `{kind}` jobs' aggregates as the study wrote them (summary.json and timing.json).")
    rows = [(p, f"{v:g}") for part in (study.summary, study.timing) for p, v in _numbers(part.get(kind, {}))]
    sec.table(TextTable(f"{kind}: aggregates", ("Entry", "Value"), tuple(rows)))
    return [sec]


def _check_manifest(where: Path, manifest: dict) -> None:
    """The fields of ``study.json`` the report starts from: ``fingerprint``, ``kinds`` and the study's name."""
    study = manifest.get("study")
    kinds = manifest.get("kinds")
    for field, ok in (("fingerprint", isinstance(manifest.get("fingerprint"), str)),
                      ("kinds", isinstance(kinds, list) and all(isinstance(k, str) for k in kinds)),
                      ("study", isinstance(study, dict) and isinstance(study.get("name"), str))):
        if not ok:
            raise DatasetError(f"{where}: field {field!r} is missing or not of the form this nnda writes; "
                               f"restore the file or run the study again")


def study_files(out: str | Path) -> StudyFiles:
    """A finished study directory's ``study.json`` and its checked ``summary.json`` and ``timing.json``; every
    Parquet table of ``checksums.json`` present checked and its footer read (a damaged one is named here)."""
    out = Path(out)
    manifest = read_json(out / MANIFEST, STUDY_FORMAT, STUDY_FORMAT_VERSION)
    _check_manifest(out / MANIFEST, manifest)
    try:
        summary, timing = read_summary(out)
    except (KeyError, TypeError, AttributeError) as exc:  # checked files, but not of the layout written
        raise DatasetError(f"{out}: summary.json or timing.json does not have the layout this nnda writes "
                           f"({type(exc).__name__}: {exc}); run the study again with --resume to rebuild "
                           f"them") from None
    if not summary.get("fingerprint") == timing.get("fingerprint") == manifest["fingerprint"]:
        raise DatasetError(f"{out}: study.json, summary.json and timing.json come from different studies; "
                           f"rerun `nnda run --resume` to rebuild them")
    for name in listed(out):
        if name.endswith(".parquet") and (out / name).exists():  # a missing table is its section's to explain
            read_schema(out, name)
    return StudyFiles(out, manifest, summary, timing)


def report_sections(out: str | Path) -> tuple[str, list[Section], list[Figure], bool]:
    """The title, sections and figures of the report of study directory ``out``, and whether it has interactive
    figures."""
    study = study_files(out)
    manifest = study.manifest
    sections: list[Section] = []
    figures: list[Figure] = []
    for kind in manifest["kinds"]:
        if kind in SECTIONS:
            sections += SECTIONS[kind](study, figures)
        else:
            sections += summary_sections(kind, study)
    return (f"nnda study report: {manifest['study']['name']}", sections, figures,
            bool(INTERACTIVE & set(manifest["kinds"])))


def build_report(out: str | Path) -> tuple[str, str, list[Figure]]:
    """Markdown text, HTML text and the figures of the report of study directory ``out``."""
    title, sections, figures, interactive = report_sections(out)
    pngs = render(figures)
    return (markdown_page(title, sections), html_page(title, sections, plotly_js() if interactive else "", pngs),
            figures)


def write_report(out: str | Path) -> Path:
    """Write ``report.md``, ``figures/`` and ``report.html`` into study directory ``out``; returns the HTML path."""
    out = Path(out)
    title, sections, figures, interactive = report_sections(out)
    return write_pages(out, title, sections, figures, plotly_js() if interactive else "")
