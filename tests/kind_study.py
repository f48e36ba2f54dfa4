"""Run a study of one job kind's table in this process and read back its results document."""

from __future__ import annotations

from pathlib import Path

from nnda.study.compare import compare
from nnda.study.config import study_from_dict
from nnda.study.results import read_summary
from nnda.study.timing import join_timing


def run_kind(out: Path, kind: str, table: dict, seed: int = 0, workers: int = 1, **study) -> dict:
    """The ``kind`` entry of the summary (its wall-clock entries joined back) of a study of ``table``, run into
    ``out``; ``study`` adds top-level fields (confidence, ...)."""
    compare(study_from_dict({"name": kind, "seed": seed, kind: table, **study}, "test"), out, workers=workers)
    summary, timing = read_summary(out)
    return join_timing(summary[kind], timing.get(kind, {}))
