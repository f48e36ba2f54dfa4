"""The adapter: detections round-trip exactly, and Stone Soup's polar model measures our azimuth."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stonesoup", reason="Stone Soup is not installed: pip install 'nnda[peers]'")

from stonesoup.types.state import State  # noqa: E402

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Sensor  # noqa: E402
from nnda.data.sensor import cart_to_polar, wrap_angle  # noqa: E402
from nnda.peers.adapter import (  # noqa: E402
    from_detections,
    measurement_model,
    to_datetime,
    to_detections,
    to_seconds,
)


def test_detections_round_trip_same_values_same_times():
    ds = generate(PRESETS["S1"], seed=1)
    model = measurement_model(ds.scenario.sensor)
    for scan in list(ds.scans())[:10]:
        times, polar = from_detections(to_detections(scan, model))
        np.testing.assert_array_equal(polar, scan.measurements)
        assert np.all(times == scan.time)
    assert to_seconds(to_datetime(198.0)) == 198.0


def test_measurement_model_is_our_polar_convention():
    sensor = Sensor(sigma_range_m=25.0, sigma_azimuth_mrad=2.0)
    model = measurement_model(sensor)
    rng = np.random.default_rng(0)
    for x, y in rng.uniform(-30_000, 30_000, (20, 2)):
        az, r = (float(v) for v in model.function(State([[x], [10.0], [y], [-5.0]])).ravel())
        r0, az0 = cart_to_polar(x, y)
        assert np.isclose(r, r0) and abs(wrap_angle(az - az0)) < 1e-9  # rad: Stone Soup's own atan2
    np.testing.assert_allclose(model.covar(), np.diag([2e-3 ** 2, 25.0 ** 2]))
    # clockwise from north: a point due east is at +pi/2
    assert np.isclose(float(model.function(State([[1e4], [0], [0], [0]]))[0, 0]), np.pi / 2)
