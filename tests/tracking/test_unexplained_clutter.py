"""The local clutter estimate that leaves out what the tracks explain, in the trackers that use it."""

from __future__ import annotations

import warnings
from functools import cache

import pytest

from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.study.metrics import run_metrics
from nnda.tracking.registry import make_tracker


@cache
def formation():
    """36 aircraft 1 km apart (a 6 x 6 grid) flying north at 150 m/s, 10-15 km from a radar of P_D 0.9 with 5
    clutter a scan over its ring, 20 scans of 2 s: a target's square (half-side 3 km) holds up to 30 of their
    contacts and a tenth of a clutter contact."""
    targets = [Target(name=f"t{i}", x_m=10_000.0 + 1_000.0 * (i % 6), y_m=-4_000.0 + 1_000.0 * (i // 6),
                      heading_deg=0.0, speed_m_s=150.0, segments=[Segment(duration_s=40.0)]) for i in range(36)]
    radar = Sensor(pd=0.9, clutter=Clutter(law="annulus", count=5))
    return generate(Scenario(name="formation", duration_s=40.0, targets=targets, sensors=(radar,)), seed=3)


def scores(name: str, params: dict) -> tuple[float, float]:
    """MOTA and mean GOSPA (m) of tracker ``name`` with ``params`` on `formation`."""
    ds = formation()
    tracker = make_tracker(name, ds.scenario.sensors, params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outputs = [tracker.step(scan) for scan in ds.scans()]
    values = run_metrics(ds, outputs).values
    return float(values["mota"]), float(values["gospa"])


@pytest.mark.parametrize(("name", "field"), [("pmbm", "clutter_estimate"), ("glmb", "clutter_estimate"),
                                             ("gnn", "clutter_estimate"), ("jpda", "clutter_estimate"),
                                             ("ekphd", "clutter"), ("cphd", "clutter")])
def test_dense_targets_confirm_sooner_without_their_own_contacts_as_clutter(name, field):
    """In a dense formation the local count is mostly the targets' own contacts: the clutter density it gives
    is hundreds of times the clutter's, the existence of their births low and confirmation late. Leaving out
    each contact itself and the tracks' expected detections, the formation is tracked sooner: MOTA up by 0.01
    to 0.04 (seen), GOSPA down by 5 to 15 %. (Equal estimates would give equal scores.)"""
    (mota_local, gospa_local), (mota, gospa) = scores(name, {field: "local"}), scores(name, {field: "unexplained"})
    assert mota > mota_local + 0.005 and gospa < 0.97 * gospa_local, (mota_local, mota, gospa_local, gospa)


def test_an_unknown_estimate_is_refused_by_name():
    with pytest.raises(Exception, match="clutter_estimate"):
        make_tracker("pmbm", formation().scenario.sensors, {"clutter_estimate": "global"})
