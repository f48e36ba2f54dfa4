"""Every preset generates the values it generated before the scenario had several sensors.

``fixtures/preset_values.json`` holds a fingerprint of each preset's run 0 at
seed 0, written by ``python tests/data/test_preset_values.py`` on commit
63ca4c6 (one radar, dataset format 1). Integer and boolean columns are
compared exactly (their SHA-256); each float column by its sum and a sum
weighted by fixed pseudo-random weights, to 1e-9 of the column's absolute
sum, so that the check holds across machines whose libm differ in the last
bit while any moved, dropped or reordered value fails it. On the machine
that wrote it, the multi-sensor generator was also compared bit for bit with
that commit's: every preset at seed 0 and at its own seed, S3 runs 0-2 at
seed 7, and scenarios with annulus/Poisson, Gaussian and placed-square
clutter, PD overrides and other radar parameters; this test keeps the values
there.
"""

from __future__ import annotations

import hashlib
import json
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import GROUPS, PRESETS

FIXTURE = Path(__file__).parent / "fixtures" / "preset_values.json"
#: seed of the weights of the weighted sums (any fixed value; PCG64 draws are the same on every machine)
WEIGHT_SEED = 20240613
#: the columns a one-sensor dataset had before the ``sensor`` column
RECORD_COLUMNS = {
    "detections": ("scan", "time", "range", "azimuth", "x", "y", "is_clutter", "target_id"),
    "truth": ("scan", "time", "target_id", "x", "y", "vx", "vy", "detected"),
}


def fingerprint(dataset) -> dict:
    """Column -> SHA-256 (integers, booleans) or [sum, weighted sum, sum of |values|] (floats)."""
    out = {}
    for record, columns in RECORD_COLUMNS.items():
        rec = getattr(dataset, record)
        assert {f.name for f in fields(rec)} >= set(columns)
        for name in columns:
            a = np.ascontiguousarray(getattr(rec, name))
            if a.dtype.kind == "f":
                w = np.random.default_rng(WEIGHT_SEED).random(a.size)
                out[f"{record}.{name}"] = [float(a.sum()), float(a @ w), float(np.abs(a).sum())]
            else:
                out[f"{record}.{name}"] = f"{a.dtype.str}:{a.size}:{hashlib.sha256(a.tobytes()).hexdigest()}"
    return out


#: the preset groups of the fixture (every preset of commit 63ca4c6)
RECORDED_GROUPS = ("train", "trajectories", "validation")


def _recorded_presets() -> dict:
    return {name: fingerprint(generate(PRESETS[name], seed=0)) for g in RECORDED_GROUPS for name in GROUPS[g]}


@pytest.fixture(scope="module")
def recorded() -> dict:
    return json.loads(FIXTURE.read_text())


@pytest.mark.parametrize("name", sorted(json.loads(FIXTURE.read_text())) if FIXTURE.is_file() else [])
def test_preset_values_unchanged(name, recorded):
    now, then = fingerprint(generate(PRESETS[name], seed=0)), recorded[name]
    assert now.keys() == then.keys()
    for column, value in then.items():
        if isinstance(value, str):
            assert now[column] == value, f"{name}: {column} changed"
        else:
            tol = 1e-9 * value[2]
            assert abs(now[column][0] - value[0]) <= tol and abs(now[column][1] - value[1]) <= tol, \
                f"{name}: {column} changed"


def test_every_preset_of_the_recorded_groups_is_recorded(recorded):
    assert {name for g in RECORDED_GROUPS for name in GROUPS[g]} == recorded.keys()


if __name__ == "__main__":  # write the fixture (done once, on the commit named in the docstring)
    FIXTURE.write_text(json.dumps(_recorded_presets(), indent=1, sort_keys=True) + "\n")
    sys.stdout.write(f"wrote {FIXTURE}\n")
