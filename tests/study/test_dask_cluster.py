"""A study of every job kind on a real Dask cluster: a scheduler and two workers, each its own process, one
worker killed mid-study; the study finishes, resumes, and writes the bytes of the same study run locally."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nnda.study.compare import compare
from nnda.study.config import load_study

pytest.importorskip("dask.distributed", reason="dask is not installed (pip install 'nnda[dask]')")
DASK = Path(sys.executable).with_name("dask")

SCENARIO = """
name = "{name}"
duration_s = 40
seed = 3
[clutter]
count = {clutter}
{targets}
"""
TARGET = """[[targets]]
name = "{name}"
x_m = {x}
y_m = 10000
heading_deg = 90
speed_m_s = 100
segments = [{{duration_s = 40}}]
"""
STUDY = """
name = "every-kind"
seed = 4
runs = 3

[trackers.gnn]
kind = "gnn"
[filters.imm]
kind = "imm"

[[scenarios]]
config = "two.toml"
[[scenarios]]
config = "one.toml"

[reentry]
runs = 4
steps = 5
[[reentry.settings]]
name = "paper"
sigma_r = 200.0
sigma_eps = 0.017
particles = [100]
filters = ["bootstrap", "ekf"]

[tbd]
runs = 3
chunk_runs = 2
ptcr_db = [8.1]
scene = { rows = 24, cols = 24, frames = 5 }
filters = [{ name = "apf", particles = 200 }]
divergence_frames = 2
steady_frames = 2
acquisition = 1
exit_reentry = { runs = 1, frames = 12, exit_frames = 3, reentry_frame = 8 }
chain = { trackers = ["gnn"] }

[pedestrian]
tests = ["test4"]
test4_runs = 4
block_runs = 2
beyond = false
bootstrap = 100
"""
#: what the aggregation writes that must not change with where the jobs ran (timing files aside)
SAME_BYTES = ("summary.json", "results.parquet", "filter_results.parquet", "reentry_results.parquet",
              "tbd_results.parquet", "tbd_snapshot.json", "pedestrian_results.parquet", "cardinality.parquet",
              "trajectories.parquet", "classifier.json")


def _write_study(root: Path) -> Path:
    (root / "two.toml").write_text(SCENARIO.format(name="two", clutter=20, targets="".join(
        TARGET.format(name=n, x=x) for n, x in (("a", -10000), ("b", 8000)))))
    (root / "one.toml").write_text(SCENARIO.format(name="one", clutter=5, targets=TARGET.format(name="a", x=0)))
    (root / "study.toml").write_text(STUDY)
    return root / "study.toml"


def _start(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen(args, stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path):
    """A scheduler on loopback and two single-threaded workers without a nanny (a killed worker stays dead),
    each a separate process; yields (scheduler address, the workers)."""
    if not DASK.exists():
        pytest.skip("the dask command line is not installed")
    scheduler_file = tmp_path / "scheduler.json"
    procs = [_start([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(scheduler_file)], tmp_path / "scheduler.log")]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        workers = [_start([str(DASK), "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                           "--name", f"w{i}", "--local-directory", str(tmp_path / f"w{i}")],
                          tmp_path / f"worker{i}.log") for i in range(2)]
        procs += workers
        from dask.distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address, workers
    finally:
        for proc in procs:
            _stop(proc)


def test_a_study_of_every_kind_survives_a_killed_worker_and_matches_the_local_run(cluster, tmp_path):
    address, workers = cluster
    study_file = _write_study(tmp_path)
    local = compare(load_study(study_file), tmp_path / "local", workers=1)
    assert set(local.plan.kinds) == {"track", "filter", "reentry", "tbd", "pedestrian"}
    total = len(local.plan.jobs)

    out = tmp_path / "on-dask"
    run = subprocess.Popen([sys.executable, "-m", "nnda", "run", "--study", str(study_file), "--out", str(out),
                            "--dask", address], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not any((out / "jobs").rglob("*.json")) and time.monotonic() < deadline and run.poll() is None:
        time.sleep(0.01)
    _stop(workers[0])  # one worker dies mid-study: the scheduler gives its work to the other
    done_when_killed = len(list((out / "jobs").rglob("*.json")))
    stdout, stderr = run.communicate(timeout=600)
    assert run.returncode == 0, stderr[-3000:]
    assert done_when_killed < total and f"{total} job(s) run, 0 resumed, on dask {address}" in stdout
    for name in SAME_BYTES:
        assert (out / name).read_bytes() == (tmp_path / "local" / name).read_bytes(), name
    assert (out / "report.html").is_file()

    resumed = subprocess.run([sys.executable, "-m", "nnda", "run", "--study", str(study_file), "--out", str(out),
                              "--dask", address, "--resume"], capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert f"0 job(s) run, {total} resumed" in resumed.stdout
    for name in SAME_BYTES:
        assert (out / name).read_bytes() == (tmp_path / "local" / name).read_bytes(), name
    shutil.rmtree(tmp_path / "local")
