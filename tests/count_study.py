"""The study file of the target-count tests (tests/study, tests/reports): a GNN beside the EK-PHD and the
CPHD, so that one tracker keeps no cardinality, one a PHD's mean and one a CPHD's distribution."""

from __future__ import annotations


def count_study(config: str, runs: int, seed: int) -> str:
    """The study's TOML text on the one scenario config file ``config`` (relative to the study file)."""
    return (f'name = "counts"\nseed = {seed}\nruns = {runs}\n'
            + "".join(f'[trackers.{k}]\nkind = "{k}"\n' for k in ("gnn", "ekphd", "cphd"))
            + f'[[scenarios]]\nconfig = "{config}"\n')
