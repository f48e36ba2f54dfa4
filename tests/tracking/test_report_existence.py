"""``lifecycle.report_existence``: the contact trackers leave a confirmed track out of their output while its
target's existence, after its misses in a row, is below the threshold, and report it again, confirmed and under
its id, at its next contact."""

from __future__ import annotations

import numpy as np
import pytest
from tests.tracking.labelled_helpers import one_target

from nnda.data.dataset import Scan
from nnda.errors import ConfigError
from nnda.tracking.lifecycle import LifecycleConfig, misses_to_hide
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker

#: scans without the target's contact: a gap of three, and none after scan `END`
GAP, END = {15, 16, 17}, 25


def _existence_after(n: int, pd_gated: float, survival: float) -> float:
    r = 1.0
    for _ in range(n):
        r = (1 - pd_gated) * survival * r / (1 - pd_gated * survival * r)
    return r


@pytest.mark.parametrize(("threshold", "survival", "pd"), [(0.5, 0.995, 0.9), (0.7, 0.995, 0.9), (0.5, 0.995, 0.6),
                                                           (0.5, 0.9, 0.3), (0.99, 0.995, 0.9)])
def test_the_misses_to_hide_are_the_first_below_the_threshold(threshold, survival, pd):
    cfg = LifecycleConfig(report_existence=threshold, survival_probability=survival, existence_confirmation=0.5,
                          existence_deletion=0.01)
    n = misses_to_hide(cfg, pd * 0.99)
    assert _existence_after(n, pd * 0.99, survival) < threshold <= _existence_after(n - 1, pd * 0.99, survival)


def test_hand_worked_values_and_the_rule_off():
    cfg = LifecycleConfig(report_existence=0.5)
    # P_D P_G = 0.891, p_S = 0.995: r = 0.956, 0.680, 0.186 after one, two, three misses
    assert [round(_existence_after(n, 0.891, 0.995), 3) for n in (1, 2, 3)] == [0.956, 0.68, 0.186]
    assert misses_to_hide(cfg, 0.891) == 3
    assert misses_to_hide(LifecycleConfig(), 0.891) == 2**62
    # a sensor that never misses a target: its first miss says the target is gone
    assert misses_to_hide(cfg, 1.0) == 1


def _shown(name: str, report_existence: float | None) -> tuple[dict, int]:
    sensor, scans = one_target()
    empty = np.empty((0, 2))
    scans = [Scan(s.index, s.time, empty if s.index in GAP or s.index > END else s.measurements) for s in scans]
    # the P_D held at the assumed 0.9 (not learnt from the gap's misses), so the misses to hide are known
    tracker = make_tracker(name, sensor, {"lifecycle": {"report_existence": report_existence, "estimate_pd": False}})
    shown = {s.index: tracker.step(s) for s in scans}
    track = int(shown[14].track_id[0])
    assert shown[14].status.tolist() == [TrackStatus.CONFIRMED]
    return shown, track


@pytest.mark.parametrize("name", ["gnn", "jpda", "mht"])
def test_a_confirmed_track_is_left_out_after_its_misses_and_comes_back_under_its_id(name):
    """At the assumed P_D 0.9 a track is left out at its third miss in a row (existence 0.19), not deleted: it
    is reported again, confirmed, at its next contact; after its target ends it shows two coasted scans, then
    only its deletion."""
    shown, track = _shown(name, 0.5)
    visible = {k for k, out in shown.items() if (out.track_id == track).any()}
    assert {15, 16} <= visible and 17 not in visible
    assert shown[18].track_id.tolist() == [track] and shown[18].status.tolist() == [TrackStatus.CONFIRMED]
    after = sorted(k for k in visible if k > END)
    assert after[:2] == [END + 1, END + 2] and END + 3 not in visible
    assert [shown[k].status.tolist() for k in after[2:]] == [[TrackStatus.DELETED]]
    # without the rule: the same track, every scan shown until its deletion, and the same states where shown
    plain, same = _shown(name, None)
    assert same == track
    for k in visible:
        np.testing.assert_array_equal(plain[k].state, shown[k].state)
    assert {17, END + 3} <= {k for k, out in plain.items() if (out.track_id == track).any()}


@pytest.mark.parametrize("name", ["pmbm", "glmb", "lmb"])
def test_a_labelled_tracker_refuses_the_contact_trackers_rule_naming_its_own(name):
    sensor, _ = one_target()
    with pytest.raises(ConfigError, match=r"lifecycle.report_existence = 0.7 .*set report_existence \(now 0.5\)"):
        make_tracker(name, sensor, {"lifecycle": {"report_existence": 0.7}})
