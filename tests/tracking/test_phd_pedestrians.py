"""The GM-PHD on Frencl (2014)'s walkers: its diagonal-noise CV (motion "cv-diagonal") on the ground radar's fixes."""

from __future__ import annotations

import numpy as np

from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.pedestrian.walkers import generate_walkers
from nnda.filters.ground_motion import DiagonalCV
from nnda.tracking.registry import make_tracker


def test_gmphd_with_the_thesis_cv_follows_the_test2_walker():
    ds = generate_walkers(PEDESTRIAN_SCENES["walk-test2"], run=0)
    params = {"preset": "pedestrian", "motion": "cv-diagonal", "pd": 0.99, "clutter": 5.0,
              "birth": {"kind": "measurement", "rate": 0.1, "speed_sigma_m_s": 2.0}}
    tracker = make_tracker("gmphd", ds.scenario.sensors, params)
    assert isinstance(tracker.motion, DiagonalCV)
    errors = []
    truth = ds.truth
    for scan in ds.scans():
        out = tracker.step(scan)
        here = truth.scan == scan.index
        if scan.index > 5 and here.any() and out.state.shape[0]:
            d = np.hypot(out.state[:, 0] - truth.x[here][0], out.state[:, 2] - truth.y[here][0])
            errors.append(d.min())
    assert len(errors) > 20 and np.median(errors) < 1.0
