"""Each compiled kernel is compiled once per run of a tracker: its arguments come in one memory layout.

An argument that sometimes arrives F-ordered or strided where it is usually C-ordered makes numba compile (or
load from its cache) a second version of the kernel in the middle of a run, ~15 ms, and one such case made a
scan of `pmbm` cost a hundred times its mean. Run in a fresh interpreter: other tests call the kernels with
arrays of their own."""

from __future__ import annotations

import json
import subprocess
import sys

PROGRAM = """
import json, sys, warnings
warnings.simplefilter("ignore")
from numba.core.registry import CPUDispatcher
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.tracking.registry import make_tracker
for name in ("gnn", "jpda", "mht", "pmbm", "glmb", "lmb", "gmphd"):
    for preset in ("S1", "S3", "S6"):
        data = generate(PRESETS[preset], seed=0)
        tracker = make_tracker(name, data.scenario.sensor, {})
        for scan in data.scans():
            tracker.step(scan)
layouts = {}
for module in [m for m in list(sys.modules.values()) if getattr(m, "__name__", "").startswith("nnda")]:
    for attr, value in vars(module).items():
        if isinstance(value, CPUDispatcher):
            for signature in value.signatures:  # the same kinds of argument in another layout
                kinds = tuple((str(getattr(a, "dtype", a)), getattr(a, "ndim", 0)) for a in signature)
                shapes = tuple(getattr(a, "layout", "") for a in signature)
                layouts.setdefault(f"{module.__name__}.{attr}", {}).setdefault(str(kinds), set()).add(shapes)
print(json.dumps({k: [sorted(v) for v in by.values() if len(v) > 1] for k, by in layouts.items()
                  if any(len(v) > 1 for v in by.values())}))
"""


def test_no_kernel_is_compiled_twice_for_a_layout():
    """gnn, jpda, mht, pmbm, glmb, lmb and the GM-PHD on S1, S3 and S6: no compiled function of nnda holds two
    versions that differ only in their arguments' memory layout."""
    out = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, check=True, timeout=600)
    twice = json.loads(out.stdout.strip().splitlines()[-1])
    assert not twice, f"kernels compiled for two layouts of the same arguments: {twice}"
