"""Track continuation (``continuation_gate``): a new track confirmed where a confirmed track lost its target in a
turn continues that track under its id, instead of the target being reported lost and found again."""

from __future__ import annotations

import numpy as np
import pytest
from tests.tracking.test_status_invariants import broken

from nnda.data.dataset import Dataset
from nnda.data.generator import generate
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import ConfigError
from nnda.tracking.continuation import continuation_pairs
from nnda.tracking.lag import FixedLag
from nnda.tracking.output import NO_CONTACT, TrackStatus
from nnda.tracking.registry import make_tracker

#: a tight IMM (little process noise, a CT model that expects gentle turns) and a quick M/N life cycle: the turn's
#: onset leaves the gate, and the new track confirms before the old one is deleted
TIGHT = {"motion": {"cv_sigma_q": 0.5, "ct_sigma_omega": 0.005},
         "lifecycle": {"confirmation": "mn", "m": 2, "n": 3, "max_misses": 5}}


def _turn() -> Dataset:
    """One target, P_D 1 and no clutter: 30 s straight, a 20 s turn at 15 m/s^2 (about 4.8 deg/s), 30 s straight."""
    sensor = Sensor(pd=1.0, clutter=Clutter(law="none"))
    target = Target(name="t", x_m=4_000.0, y_m=12_000.0, heading_deg=70.0, speed_m_s=180.0,
                    segments=[Segment(duration_s=30.0), Segment(duration_s=20.0, normal_accel=15.0),
                              Segment(duration_s=30.0)])
    return generate(Scenario(name="turn", duration_s=80.0, targets=[target], sensors=(sensor,)), seed=7)


def _run(name: str, gate: float):
    dataset = _turn()
    tracker = make_tracker(name, dataset.scenario.sensors, {**TIGHT, "continuation_gate": gate})
    return tracker, [tracker.step(scan) for scan in dataset.scans()]


def _ids(outs, status: TrackStatus) -> set[int]:
    return {int(i) for out in outs for i, s in zip(out.track_id, out.status) if s == status}


@pytest.mark.parametrize("name", ["gnn", "jpda"])
def test_the_turning_target_keeps_one_track_with_continuation(name):
    tracker, outs = _run(name, 0.0)
    assert len(_ids(outs, TrackStatus.CONFIRMED)) == 2 and "continued" not in tracker.track_management()
    tracker, outs = _run(name, 30.0)
    confirmed = _ids(outs, TrackStatus.CONFIRMED)
    assert len(confirmed) == 1 and tracker.track_management()["continued"] == tracker.continued == 1
    (track,) = confirmed
    # confirmed from its first confirmation to the end, with a contact every scan after the join
    rows = [(out.scan, int(out.status[out.track_id == track][0]), int(out.contact[out.track_id == track][0]))
            for out in outs if (out.track_id == track).any()]
    first = next(k for k, (_, s, _) in enumerate(rows) if s == TrackStatus.CONFIRMED)
    assert all(s == TrackStatus.CONFIRMED for _, s, _ in rows[first:])
    # the new track that continued it: reported deleted, without a contact, and never confirmed
    (gone,) = _ids(outs, TrackStatus.DELETED) - {track}
    ends = [out for out in outs if (out.status[out.track_id == gone] == TrackStatus.DELETED).any()]
    assert len(ends) == 1 and ends[0].contact[ends[0].track_id == gone][0] == NO_CONTACT
    join = ends[0].scan
    assert all(c != NO_CONTACT for k, _, c in rows if k >= join)


def test_pairs_use_the_closest_model_and_match_one_to_one():
    rng = np.random.default_rng(3)
    d = 4
    A = rng.normal(size=(2, 3, d, d))
    old_P = A @ A.transpose(0, 1, 3, 2) + np.eye(d)
    old_x = rng.normal(size=(2, 3, d)) * 100
    B = rng.normal(size=(3, d, d))
    new_P = B @ B.transpose(0, 2, 1) + np.eye(d)
    new_x = rng.normal(size=(3, d)) * 100
    # the least squared distance over each old track's models, written out pair by pair
    d2 = np.array([[min(float((new_x[n] - old_x[o, j]) @ np.linalg.solve(new_P[n] + old_P[o, j],
                                                                       new_x[n] - old_x[o, j])) for j in range(3))
                    for n in range(3)] for o in range(2)])
    allowed = np.ones((2, 3), bool)
    o, n = continuation_pairs(old_x, old_P, new_x, new_P, allowed, np.inf)
    best = min(((d2[0, a] + d2[1, b], a, b) for a in range(3) for b in range(3) if a != b))
    assert o.tolist() == [0, 1] and n.tolist() == [best[1], best[2]]
    # the gate and the allowed pairs bound what may join
    gate = float(np.sort(d2.ravel())[0]) * (1 + 1e-9)
    o, n = continuation_pairs(old_x, old_P, new_x, new_P, allowed, gate)
    assert list(zip(o.tolist(), n.tolist())) == [tuple(np.argwhere(d2 == d2.min())[0])]
    assert continuation_pairs(old_x, old_P, new_x, new_P, ~allowed, np.inf)[0].size == 0
    # a new track that only one model of the old one explains still joins it
    near = old_x[1, 2] + 1e-3
    o, n = continuation_pairs(old_x[1:], old_P[1:], near[None], new_P[:1], np.ones((1, 1), bool), 1.0)
    assert (o.tolist(), n.tolist()) == ([0], [0])


def test_a_negative_gate_is_refused_and_mht_has_no_such_field():
    sensor = _turn().scenario.sensors
    with pytest.raises(ConfigError, match="continuation_gate"):
        make_tracker("gnn", sensor, {"continuation_gate": -1.0})
    with pytest.raises(ConfigError, match="continuation_gate"):
        make_tracker("mht", sensor, {"continuation_gate": 10.0})


def test_the_count_reaches_the_results_table_only_where_continuation_is_on():
    from nnda.study.track import run_tracker
    from nnda.study.track_job import scalars, series
    from nnda.study.track_results import results_table

    dataset = _turn()
    runs = [run_tracker(dataset, "gnn", {**TIGHT, "continuation_gate": gate}) for gate in (30.0, 0.0)]
    base = {"scenario": "turn", "tracker": "gnn", "kind": "gnn", "run": 0, "seed": 0, "dataset_digest": "d",
            "n_scans": dataset.n_scans, "n_targets": 1, "ownership": "contacts"}
    records = [base | {"metrics": scalars(r.scores), "series": series(r.scores), "track_management": r.management}
               for r in runs]
    assert results_table(records).column("continued_tracks").to_pylist() == [1, None]
    assert "continued_tracks" not in results_table(records[1:]).column_names


@pytest.mark.parametrize("rule", ["mn", "adaptive"])
def test_a_lagged_output_keeps_the_continued_track(rule):
    """With a lag of 3 the target still has one confirmed track, and the lagged stream keeps the status
    invariants (no id back from deletion, none back from confirmed to preliminary)."""
    dataset = _turn()
    params = {**TIGHT, "continuation_gate": 30.0, "lifecycle": {**TIGHT["lifecycle"], "confirmation": rule}}
    tracker = make_tracker("gnn", dataset.scenario.sensors, params)
    fixed = FixedLag(tracker, 3)
    lagged = [late for scan in dataset.scans() if (late := fixed.step(scan)[1]) is not None] + fixed.flush()
    assert not broken(lagged), broken(lagged)
    if rule == "mn":
        assert tracker.continued == 1 and len(_ids(lagged, TrackStatus.CONFIRMED)) == 1
