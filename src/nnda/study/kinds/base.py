"""What a job kind is: the contract between the study engine and one kind of work.

A study file holds one table (or a few top-level fields) per kind it uses;
the engine (`nnda.study.plan`, `nnda.study.runner`, `nnda.study.results`)
knows only this contract::

    kind = KINDS["reentry"]
    kind.fields                      # its study-file fields: {name: (annotation, pydantic Field)}
    kind.work                        # how a study file names its work, e.g. "[trackers.<label>]"
    kind.given(study)                # does this study ask for it?
    kind.check(study)                # cross-field checks (ValueError), run when the study file is read
    plan = kind.plan(study, where)   # every input checked; plan.jobs: the independent Jobs, keyed
    record = kind.run(job.spec)      # one job, in any process: a JSON-ready dict
    summary, timing, files = kind.aggregate(plan, records)   # in plan order: summary.json and timing.json
                                     # entries, and the kind's own files ({name: pyarrow Table, JSON or None})

The measures a kind's records hold are the registry's entries for the kind
(`nnda.study.measures.for_kind`: a measure names the kinds it applies to).
A kind whose table sets sizes (runs, particles, frame sizes, resamples)
estimates its memory from them in ``plan``, before any job, and refuses a
study whose largest job or aggregation would need more than the table's
``max_memory_gib`` (`check_memory`; default `MAX_MEMORY_GIB`).
Records hold no wall-clock time outside their ``timing`` entry, so
everything but ``timing.json`` and ``timing.*`` tables is the same, byte
for byte, for the same study and seed.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Annotated, Any, Protocol

import pyarrow as pa
from pydantic import ConfigDict, Field

from nnda.errors import ConfigError
from nnda.files import canonical, digest
from nnda.version import __version__

#: study-file models: unknown keys refused, values frozen, no NaN or infinity
STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
#: labels become file and directory names, so they are kept to a safe alphabet (and start with no dot)
Label = Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_\-][A-Za-z0-9_.\-]*$")]


@dataclass(frozen=True)
class Job:
    """One independent unit of a study's work; picklable, no open files.

    ``kind`` is the registry name of its job kind, ``key`` a SHA-256 over
    what determines its record (a saved record is reused on resume only
    under the same key), ``relpath`` where its record lives in the study
    directory, ``title`` how messages name it, ``spec`` what the kind's
    ``run`` needs.
    """

    kind: str
    key: str
    relpath: str
    title: str
    spec: Any


class KindPlan(Protocol):
    """A kind's checked part of a study: its jobs in plan order and its entries of ``study.json``."""

    jobs: tuple[Job, ...]

    def manifest(self) -> dict: ...


@dataclass(frozen=True, eq=False)  # compared and hashed by identity: a kind is one registry entry
class JobKind:
    """A job kind: its study-file fields and the functions the engine calls (module docstring)."""

    name: str
    fields: Mapping[str, tuple[Any, Any]]
    work: str
    given: Callable[[Any], bool]
    plan: Callable[[Any, str], KindPlan]
    run: Callable[[Any], dict]
    aggregate: Callable[[Any, list[dict]], tuple[dict, dict, dict[str, pa.Table | dict | None]]]
    check: Callable[[Any], None] = lambda study: None


def job_key(what: Mapping[str, Any]) -> str:
    """SHA-256 of ``what`` determines a record, with the nnda version (a new release recomputes every job)."""
    return digest(canonical({"nnda": __version__, **what}))


def study_table(study, name: str):
    """A kind's own table ``name`` (a config with ``seed`` and ``confidence`` fields) with the study's seed and
    confidence in them."""
    return getattr(study, name).model_copy(update={"seed": study.seed, "confidence": study.confidence})


def study_seed_only(name: str) -> Callable[[Any], None]:
    """The check of a kind whose table ``name`` is a config with its own seed and confidence fields: they are
    the study's, so the table may not give them."""
    def check(study) -> None:
        table = getattr(study, name)
        if table is not None and {"seed", "confidence"} & table.model_fields_set:
            raise ValueError(f"{name}: seed and confidence are the study's: give them at the top of the study file")
    return check


@dataclass(frozen=True)
class TablePlan:
    """The checked part of a kind with a table of its own: the table (`study_table`) and the jobs."""

    config: Any
    jobs: tuple[Job, ...]

    def manifest(self) -> dict:
        return {}  # the table is in the manifest's study


#: the most memory (GiB) one job, or the aggregation of a study's records, may need by its kind's estimate
#: (the tables' ``max_memory_gib``, ``--max-memory-gib``): a few GiB of working memory per job on a 24 GiB machine
MAX_MEMORY_GIB = 4.0
#: the field of a kind's table that raises it
MEMORY_FIELD = "max_memory_gib"


def human_bytes(n: float) -> str:
    """``n`` bytes in binary units: '512 B', '3.2 MiB', '1.63 TiB'."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024
    raise AssertionError("unreachable")


@dataclass(frozen=True)
class MemoryPart:
    """One part of a kind's memory estimate: ``what`` needs it (a job, the aggregation), ``sizes`` the table's
    fields and values it grows with ("runs = 100 x steps = 55"), ``lower`` what to lower to shrink it, and
    ``bytes`` the estimate."""

    what: str
    sizes: str
    lower: str
    bytes: float


def check_memory(where: str, table: str | None, parts: list[MemoryPart], limit_gib: float | None,
                 command: str | None = None) -> None:
    """ConfigError naming the study file, the table (None: the study's top-level fields) and its sizes, the
    estimate and the limit when the largest of ``parts`` needs more than ``limit_gib`` GiB (None: the default,
    `MAX_MEMORY_GIB`), and how to raise it (the table's `MEMORY_FIELD`, or ``--max-memory-gib`` of ``nnda run``
    and of ``nnda <command>``). Arithmetic on the config: it runs when the study is planned, before anything is
    allocated."""
    limit_gib = MAX_MEMORY_GIB if limit_gib is None else limit_gib
    worst = max(parts, key=lambda p: p.bytes)
    if worst.bytes <= limit_gib * 2**30:
        return
    here = f"[{table}]: " if table is not None else ""
    field = f"in the [{table}] table" if table is not None else "at the top of the study file"
    commands = "nnda run" + (f", nnda {command}" if command is not None else "")
    raise ConfigError(
        f"{where}: {here}{worst.what} would need about {human_bytes(worst.bytes)} ({worst.sizes}), above the "
        f"limit of {human_bytes(limit_gib * 2**30)} ({MEMORY_FIELD} = {limit_gib:g}); lower {worst.lower}, or raise "
        f"the limit with {MEMORY_FIELD} {field} or --max-memory-gib ({commands}) if the machine has the memory")
