"""The CPHD's cardinality support 0..N_max: by default it grows with the expected target count, so a scene of more
targets than ``max_cardinality`` keeps its count; held fixed, a count piled up at N_max is counted and warned of
once a run."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_phd_cap import many_targets

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Sensor
from nnda.errors import BoundWarning, ConfigError
from nnda.tracking.phd import cphd
from nnda.tracking.registry import make_tracker


def test_the_support_doubles_until_it_holds_the_expected_count():
    p = np.zeros(11)
    p[6] = 1.0  # mean 6 on 0..10
    assert cphd.support_for(p, 10, 1.5) is p  # 1.5 x 6 = 9 fits
    p = np.zeros(11)
    p[10] = 1.0  # mean 10: needs 15, so 0..20
    grown = cphd.support_for(p, 10, 1.5)
    assert len(grown) == 21 and grown[10] == 1.0 and grown.sum() == 1.0
    p = np.zeros(11)
    p[[9, 10]] = 0.5  # mean 9.5 x 4 = 38: 0..40, the smallest 10 x 2^k holding it
    assert len(cphd.support_for(p, 10, 4.0)) == 41


def test_the_support_follows_more_targets_than_max_cardinality():
    """40 targets against max_cardinality = 20: held fixed, the count stops at 20, with one BoundWarning naming the
    field and every such scan counted; grown (the default), it passes 20 without a warning."""
    ds = generate(many_targets(40, scans=10), 0)
    means = {}
    for per_target in (None, 1.5):
        tracker = make_tracker("cphd", ds.scenario.sensor, {"max_cardinality": 20, "clutter": "scan",
                                                            "cardinality_per_target": per_target})
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for scan in ds.scans():
                tracker.step(scan)
        bound = [str(w.message) for w in caught if issubclass(w.category, BoundWarning)
                 and "max_cardinality" in str(w.message)]
        means[per_target] = tracker.cardinality.mean
        if per_target is None:
            assert len(bound) == 1 and bound[0].startswith("cphd, t = ") and "max_cardinality = 20" in bound[0]
            assert tracker.n_cardinality_capped > 1 and len(tracker.distribution) == 21
        else:
            assert bound == [] and tracker.n_cardinality_capped == 0 and len(tracker.distribution) > 21
    assert means[None] <= 20.0 < 30.0 < means[1.5], means
    assert make_tracker("cphd", Sensor()).config.cardinality_per_target == 1.5


def test_the_growth_changes_nothing_at_a_few_targets():
    """S3 (eight targets, 100 clutter points a scan): the same tracks and cardinality with the support growing as
    with it fixed (1.5 x a handful of targets is far below the default max_cardinality of 100)."""
    ds = generate(PRESETS["S3"].model_copy(update={"duration_s": 60.0}), 1)
    outputs, dists = {}, {}
    for per_target in (None, 1.5):
        tracker = make_tracker("cphd", ds.scenario.sensor, {"cardinality_per_target": per_target})
        outputs[per_target] = [tracker.step(scan) for scan in ds.scans()]
        dists[per_target] = tracker.distribution
    for a, b in zip(outputs[None], outputs[1.5], strict=True):
        np.testing.assert_array_equal(a.track_id, b.track_id)
        np.testing.assert_array_equal(a.state, b.state)
    np.testing.assert_array_equal(dists[None], dists[1.5])


@pytest.mark.parametrize("value", [0.5, 0])
def test_a_growth_factor_below_one_is_refused(value):
    with pytest.raises(ConfigError, match="cardinality_per_target"):
        make_tracker("cphd", Sensor(), {"cardinality_per_target": value})


def test_the_support_holds_the_births_too():
    """A posterior of mean 10 on 0..100 holds 1.5 x 10 as it is, but not 1.5 x (10 + 1,000 births): then the
    support doubles until it does (1,600)."""
    p = np.zeros(101)
    p[10] = 1.0
    assert cphd.support_for(p, 100, 1.5) is p
    grown = cphd.support_for(p, 100, 1.5, births=1_000.0)
    assert len(grown) == 1_601 and grown[10] == 1.0 and grown.sum() == 1.0
