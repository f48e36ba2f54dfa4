"""Absolute times in an imported file: ISO 8601 text or Arrow/Parquet timestamps, as nanoseconds since 1970 (UTC).

A time column holds either numbers (seconds on the user's own clock, read
by the importer as before) or absolute times: an Arrow timestamp or date
column (a CSV reader infers one from uniform ISO text; Parquet stores one),
or text such as ``2016-01-12 13:02:11.218``, ``2016-01-12T13:02:11Z`` or
``2016-01-12T14:02:11.5+01:00`` (``T`` or a space, optional fraction,
optional ``Z`` or offset). A time without a zone is UTC. Everything is
parsed by Arrow's casts, vectorised; a text that is not a time is found by
bisection (a few casts), never by a loop over rows.

The importer subtracts an origin (`default_origin_ns`) in integer
nanoseconds before converting to seconds (float64), so times a few hours
apart keep their full resolution.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from fractions import Fraction

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from nnda.errors import DatasetError

#: nanoseconds per second
NS = 1_000_000_000
#: text that is meant as a date or time (its first non-empty cell starts so): parsed as one, else refused
_LOOKS_LIKE_DATE = re.compile(r"\s*[0-9]{4}-[0-9]{2}-[0-9]{2}")
#: text ending in a time of day with a zone (Z or an offset): parsed as zoned
_ZONED = r"[0-9]{2}:[0-9]{2}(?::[0-9]{2}(?:\.[0-9]+)?)?\s*(?:[Zz]|[+-][0-9]{2}(?::?[0-9]{2})?)\s*$"
#: how a time looks, for messages
EXAMPLE = "ISO 8601 such as 2016-01-12 13:02:11.218, 2016-01-12T13:02:11Z or 2016-01-12T14:02:11+01:00"


def is_absolute(col: pa.ChunkedArray) -> bool:
    """Does ``col`` hold absolute times (a timestamp or date column, or text whose first cell is a date)?"""
    if pa.types.is_timestamp(col.type) or pa.types.is_date(col.type):
        return True
    if not (pa.types.is_string(col.type) or pa.types.is_large_string(col.type)):
        return False
    valid = col.drop_null()
    return len(valid) > 0 and bool(_LOOKS_LIKE_DATE.match(valid[0].as_py()))


def absolute_ns(col: pa.ChunkedArray, where: Callable[[int], str]) -> np.ndarray:
    """``col`` (absolute times, `is_absolute`) as int64 ns since 1970-01-01 UTC, shape (N,); DatasetError
    naming ``where(row)`` and the value at the first empty cell or text that is not a time."""
    if col.null_count:
        row = int(pc.index(pc.is_null(col), True).as_py())
        raise DatasetError(f"{where(row)}: an empty cell (a time, {EXAMPLE})")
    if pa.types.is_date(col.type):
        col = pc.cast(col, pa.timestamp("s"))
    if pa.types.is_timestamp(col.type):
        utc = pa.timestamp("ns", tz="UTC" if col.type.tz is not None else None)
        try:
            return pc.cast(col, utc).cast(pa.int64()).to_numpy(zero_copy_only=False)
        except pa.ArrowInvalid:  # beyond the years 1677-2262
            row = _first_failing(col, utc)
            raise DatasetError(f"{where(row)}: {col[row].as_py()!r} is outside the years 1677-2262 nnda "
                               f"reads") from None
    col = pc.utf8_trim_whitespace(col.combine_chunks())
    zoned = pc.match_substring_regex(col, _ZONED)
    ns = np.empty(len(col), dtype=np.int64)
    for tz, mask in (("UTC", zoned), (None, pc.invert(zoned))):
        part = pc.filter(col, mask)
        ty = pa.timestamp("ns", tz=tz)
        try:
            parsed = pc.cast(part, ty)
        except pa.ArrowInvalid:
            i = _first_failing(part, ty)
            row = int(np.flatnonzero(mask.to_numpy(zero_copy_only=False))[i])
            raise DatasetError(f"{where(row)}: {part[i].as_py()!r} is not a time ({EXAMPLE}; no zone: UTC)") from None
        ns[mask.to_numpy(zero_copy_only=False)] = parsed.cast(pa.int64()).to_numpy(zero_copy_only=False)
    return ns


def _first_failing(values: pa.Array | pa.ChunkedArray, ty: pa.DataType) -> int:
    """Index of the first of ``values`` that does not cast to ``ty`` (some does), by bisection on prefixes."""
    lo, hi = 0, len(values)  # the prefix of length lo casts, the prefix of length hi does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            pc.cast(values[lo:mid], ty)
            lo = mid
        except pa.ArrowInvalid:
            hi = mid
    return lo


def default_origin_ns(first: Sequence[int | None], period_s: Sequence[float], reports: Sequence[bool]) -> int:
    """The time origin (ns since 1970 UTC) of absolute times: per sensor with rows (``first``: its first time,
    ns), a report sensor's start of the window holding its first report (windows of ``period_s`` counted from
    1970-01-01 00:00 UTC, so 10 s windows start on whole tens of seconds), a sweep sensor's first time less
    one period; the earliest of them, so every time lies after it."""
    starts = []
    for t0, period, report in zip(first, period_s, reports):
        if t0 is None:
            continue
        step = round(period * NS)
        starts.append(-(-t0 // step) * step - step if report else t0 - step)
    return min(starts)


def utc_text(ns: int) -> str:
    """``ns`` (since 1970 UTC) as ISO 8601 text in UTC, with the fraction it needs: 2016-01-12T13:02:10Z."""
    text = np.datetime_as_string(np.datetime64(int(ns), "ns"), unit="ns")
    day, _, fraction = text.partition(".")
    fraction = fraction.rstrip("0")
    return day + (f".{fraction}" if fraction else "") + "Z"


def seconds_after(ns: np.ndarray, origin_ns: int) -> np.ndarray:
    """Times ``ns`` (int64 ns) as float64 seconds after ``origin_ns``: the difference taken exactly, then
    divided once."""
    return (ns - np.int64(origin_ns)).astype(np.float64) / NS


def origin_ns_of(time_origin: float) -> int:
    """A ``--time-origin`` given for absolute times (seconds since 1970 UTC) in ns, from the float's exact
    value."""
    return round(Fraction(time_origin) * NS)
