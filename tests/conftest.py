"""Shared fixtures: small scenarios built from the public config API, and a small disk for write faults."""

from __future__ import annotations

import os
import subprocess

import pytest

from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Target


def straight_target(name: str = "A", **kw) -> Target:
    base = dict(name=name, x_m=-10_000.0, y_m=10_000.0, heading_deg=90.0, speed_m_s=100.0,
                segments=[Segment(duration_s=40.0)])
    base.update(kw)
    return Target(**base)


@pytest.fixture
def small_scenario() -> Scenario:
    """Two targets, 20 scans, light clutter: fast to generate and to write."""
    return Scenario(
        name="small", duration_s=40.0, seed=3,
        targets=[straight_target("A"),
                 straight_target("B", x_m=12_000.0, y_m=-8_000.0, heading_deg=200.0,
                                 segments=[Segment(duration_s=20.0), Segment(duration_s=20.0, normal_accel=5.0)],
                                 missed_scans=[4, 5])],
        clutter=Clutter(count=10),
        process_noise=ProcessNoise(),
    )


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs (root only) for full and read-only disks; skipped where mounting is not allowed.

    ``mount -o remount,ro`` makes it read-only. It is unmounted afterwards; a
    file still open on it fails the test.
    """
    mount = tmp_path / "disk"
    mount.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    yield mount
    done = subprocess.run(["umount", str(mount)], capture_output=True, text=True)
    if done.returncode != 0:  # a file is still open there: detach the disk, and fail the test that left it
        subprocess.run(["umount", "--lazy", str(mount)], check=False)
        pytest.fail(f"{mount} was still in use after the test ({done.stderr.strip()}): an open file left behind?")
