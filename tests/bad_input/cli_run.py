"""Running the command line in the bad-input suite, the checks of a refusal, and the tiny scenario."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

#: a scenario of three 2-s scans, one target at 12 km north flying east, 5 clutter points per scan
TINY_TOML = """name = "tiny"
duration_s = 6
seed = 2
[clutter]
count = 5
[[targets]]
name = "a"
x_m = 0
y_m = 12000
heading_deg = 90
speed_m_s = 100
segments = [{duration_s = 6}]
"""

TINY = {"name": "tiny", "duration_s": 6, "seed": 2, "clutter": {"count": 5},
        "targets": [{"name": "a", "x_m": 0, "y_m": 12000, "heading_deg": 90, "speed_m_s": 100,
                     "segments": [{"duration_s": 6}]}]}


@dataclass(frozen=True)
class Outcome:
    code: int
    out: str
    err: str


def nnda_process(*args, cwd: Path) -> Outcome:
    """Run ``python -m nnda`` in a new process with ``cwd`` as working directory."""
    done = subprocess.run([sys.executable, "-m", "nnda", *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          timeout=120)
    return Outcome(done.returncode, done.stdout, done.stderr)


def assert_one_line_error(outcome: Outcome, *fragments: str) -> None:
    """Exit status 2 and one plain line "error: ..." holding every fragment; no traceback."""
    assert "Traceback" not in outcome.err, outcome.err
    assert outcome.code == 2, (outcome.code, outcome.err)
    assert outcome.err.startswith("error: ") and outcome.err.count("\n") == 1, outcome.err
    for fragment in fragments:
        assert fragment in outcome.err, (fragment, outcome.err)


