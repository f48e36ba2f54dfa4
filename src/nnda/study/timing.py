"""A kind's results document split into what is the same for the same seed and what the clock measured.

    kept, timing = split_timing(doc)      # kept -> summary.json, timing -> timing.json
    doc == join_timing(kept, timing)      # the whole document again, for a report

A job kind's aggregate may build one document with its runtimes inside;
`split_timing` takes out every `TIMING_KEYS` entry at any depth so the rest
is byte-identical between two runs of the same study.
"""

from __future__ import annotations

from nnda.errors import DatasetError

#: the wall-clock entries of a kind's results document (they change between two runs of the same study)
TIMING_KEYS = ("runtime_s", "time_per_scan_s", "seconds", "ms_per_frame")


def split_timing(doc):
    """``doc`` (nested dicts and lists) without its `TIMING_KEYS` entries, and those entries in the same
    nesting (lists keep their positions, {} where nothing was timed): the first is the same for the same
    config and seed, byte for byte."""
    if isinstance(doc, dict):
        kept, timing = {}, {}
        for k, v in doc.items():
            if k in TIMING_KEYS:
                timing[k] = v
                continue
            kept[k], t = split_timing(v)
            if t:
                timing[k] = t
        return kept, timing
    if isinstance(doc, list):
        parts = [split_timing(v) for v in doc]
        timed = [t for _, t in parts]
        return [k for k, _ in parts], (timed if any(timed) else {})
    return doc, {}


def join_timing(doc, timing, where: str = ""):
    """The inverse of `split_timing`: ``doc`` with ``timing``'s entries put back. Two documents that do not
    nest alike (a list of another length) are a DatasetError naming the entry (``where``: its path so far)."""
    if isinstance(doc, dict) and isinstance(timing, dict):
        out = {k: join_timing(v, timing.get(k, {}), f"{where}.{k}" if where else str(k)) for k, v in doc.items()}
        return out | {k: v for k, v in timing.items() if k in TIMING_KEYS}
    if isinstance(doc, list) and isinstance(timing, list):
        if len(doc) != len(timing):
            raise DatasetError(f"timing.json does not match summary.json at {where or 'the top level'}: "
                               f"{len(timing)} timed entries for {len(doc)} results; run the study again with "
                               f"--resume to rebuild them")
        return [join_timing(d, t, f"{where}[{i}]") for i, (d, t) in enumerate(zip(doc, timing))]
    return doc
