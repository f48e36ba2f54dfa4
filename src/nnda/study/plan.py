"""A study resolved into independent jobs, every input checked first.

`plan_study` asks each job kind the study uses (`nnda.study.kinds.KINDS`,
in registry order) for its part: the kind reads every file it needs (model
files, datasets, configs) and builds what it will run once, so a wrong
name, a missing file or a value out of range fails with a clear message
before any job runs. The plan's jobs are the kinds' jobs in that order; the
study's *fingerprint* hashes every job key.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from nnda.files import digest
from nnda.study.kinds import KINDS
from nnda.study.kinds.base import Job, KindPlan
from nnda.version import __version__

STUDY_FORMAT = "nnda.study"
#: 2: the job kinds the study ran (``kinds``) and each kind's entries; a study directory of version 1 (before
#: the engine ran every kind) is refused by resume and report, naming the version: run it again
STUDY_FORMAT_VERSION = 2


@dataclass(frozen=True)
class StudyPlan:
    """The checked study: each kind's plan (by kind name, registry order) and every job, in plan order."""

    study: Any
    kinds: dict[str, KindPlan]
    jobs: tuple[Job, ...]

    @property
    def fingerprint(self) -> str:
        return digest(*(j.key.encode() for j in self.jobs))

    def manifest(self) -> dict:
        """The ``study.json`` content: what was run, on what, with which inputs (each kind adds its entries)."""
        head = {"format": STUDY_FORMAT, "format_version": STUDY_FORMAT_VERSION, "nnda_version": __version__,
                "fingerprint": self.fingerprint, "study": self.study.model_dump(mode="json"),
                "kinds": list(self.kinds), "jobs": len(self.jobs)}
        for part in self.kinds.values():
            head.update(part.manifest())
        return head


def plan_study(study, where: str = "study") -> StudyPlan:
    """Check every input of ``study`` and list its jobs; ``where`` names the study in error messages."""
    kinds = {name: kind.plan(study, where) for name, kind in KINDS.items() if kind.given(study)}
    return StudyPlan(study, kinds, tuple(job for part in kinds.values() for job in part.jobs))
