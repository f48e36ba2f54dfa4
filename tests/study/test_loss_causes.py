"""Loss causes on hand-made tracker outputs with a known answer per loss, and on tracker runs: the causes
always add up to the hit rate's association losses."""

from __future__ import annotations

import pytest
from tests.study.test_metrics import Builder

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Target
from nnda.study.loss_causes import LOSS_CAUSES, loss_causes
from nnda.study.metrics import ScoredRun, run_metrics
from nnda.tracking.output import TrackStatus as S
from nnda.tracking.registry import make_tracker


@pytest.fixture(scope="module")
def dataset():
    """Targets A (undetected in scans 8 and 9) and B (always detected), 20 scans, three clutter contacts a scan."""
    targets = [Target(name=n, x_m=x, y_m=12_000.0, heading_deg=90.0, speed_m_s=100.0, missed_scans=gaps,
                      segments=[Segment(duration_s=40.0)])
               for n, x, gaps in (("A", -10_000.0, [8, 9]), ("B", 5_000.0, []))]
    sc = Scenario(name="gaps", duration_s=40.0, targets=targets, clutter=Clutter(law="annulus", count=3),
                  process_noise=ProcessNoise(model="none"))
    return generate(sc, seed=2)


def scripted(ds, reinitiated: bool = True):
    """A's track 10: misses scan 3 before its confirmation (initiation), takes clutter in 5 (wrong
    contact), coasts past A in 6 (missed), coasts through the gap 8-9 and past A in 10 (missed after the
    gap), is deleted in 11; A waits in 11 and 12 (gap deletion) for track 20 from scan 13.
    B's track 11 coasts past B in 8-10 (missed), is deleted in 11; B waits in 11 and 12 (break) for 21."""
    b = Builder(ds)
    for k in range(2, 12):
        status = S.DELETED if k == 11 else S.PRELIMINARY if k < 4 else S.CONFIRMED
        row = {3: None, 5: b.contact(5, -1), 6: None, 8: None, 9: None, 10: None, 11: None}.get(k, -2)
        b.add(k, 10, status, b.contact(k, 0) if row == -2 else row, xy=(0.0, 0.0))
        b.add(k, 11, status if k >= 4 else S.PRELIMINARY, b.contact(k, 1) if k < 8 else None, xy=(0.0, 0.0))
    for k in range(13, 21 if reinitiated else 13):
        for track, target in ((20, 0), (21, 1)):
            b.add(k, track, S.PRELIMINARY if k < 15 else S.CONFIRMED, b.contact(k, target))
    return b.outputs()


def test_each_loss_gets_its_scripted_cause(dataset):
    outputs = scripted(dataset)
    causes = loss_causes(ScoredRun(dataset, outputs))
    assert causes == {"initiation": 1, "wrong_contact": 1, "missed_after_gap": 1, "missed_contact": 1 + 3,
                      "gap_deletion": 2, "break": 2}
    assert sum(causes.values()) == run_metrics(dataset, outputs).losses


def test_a_target_never_tracked_again_keeps_the_cause_of_its_track_end(dataset):
    cut = scripted(dataset, reinitiated=False)
    causes = loss_causes(ScoredRun(dataset, cut))
    assert causes["gap_deletion"] == 2 + 8 and causes["break"] == 2 + 8
    assert sum(causes.values()) == run_metrics(dataset, cut).losses


@pytest.mark.parametrize("kind", ["gnn", "mht"])
def test_the_causes_add_up_to_the_losses_of_a_tracker_run(kind):
    ds = generate(PRESETS["S5"], seed=3)
    tracker = make_tracker(kind, ds.scenario.sensor)
    outputs = [tracker.step(scan) for scan in ds.scans()]
    causes = loss_causes(ScoredRun(ds, outputs))
    assert list(causes) == list(LOSS_CAUSES) and min(causes.values()) >= 0
    assert sum(causes.values()) == run_metrics(ds, outputs).losses
