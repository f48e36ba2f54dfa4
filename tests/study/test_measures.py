"""The measure registry: its entries are consistent, and a run's record holds exactly its measures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.reports.study_summary import HEADLINES
from nnda.reports.study_tables import scenario_table
from nnda.study.measures import (
    FILTER_MEASURES,
    MEASURES,
    RUN_MEASURES,
    SERIES_MEASURES,
    TIME,
    TRACK_MEASURES,
    for_kind,
    measure,
)
from nnda.study.metrics import run_metrics
from nnda.study.track_job import scalars, series
from nnda.tracking.registry import make_tracker


def test_every_entry_is_complete_and_consistent():
    keys = [m.key for m in MEASURES]
    assert len(keys) == len(set(keys))
    assert len({m.series_name for m in SERIES_MEASURES}) == len(SERIES_MEASURES)
    for m in MEASURES:
        low, high = m.bounds
        assert low < high and m.better in ("higher", "lower", "none") and m.label, m.key
        assert m.fmt.format(1.5 * m.scale)
        assert m.title.startswith(m.label) and (m.unit in m.title)
    assert [m.key for m in MEASURES if m.timing] == [TIME.key]
    assert all(h.sense != 0 for h in HEADLINES)
    assert measure("mota").bounds == (-math.inf, 1.0) and measure("hit_rate").bounds == (0.0, 100.0)
    with pytest.raises(KeyError, match="no measure 'nope'; registered: target_contacts, hits"):
        measure("nope")


def test_a_run_record_holds_every_run_measure_and_series():
    ds = generate(PRESETS["S3"], seed=1)
    tracker = make_tracker("gnn", ds.scenario.sensor)
    m = run_metrics(ds, [tracker.step(scan) for scan in ds.scans()])
    record = scalars(m)
    assert list(record) == [ms.key for ms in RUN_MEASURES]
    for ms in RUN_MEASURES:
        assert isinstance(record[ms.key], int if ms.integer and not ms.per_scan else float), ms.key
        low, high = ms.bounds
        assert low <= record[ms.key] <= high, ms.key
    per_scan = series(m)
    assert list(per_scan) == [ms.series_name for ms in SERIES_MEASURES]
    for ms in SERIES_MEASURES:
        assert len(per_scan[ms.series_name]) == ds.n_scans
        assert record[ms.key] == float(np.mean(per_scan[ms.series_name]))


def test_the_scenario_table_has_a_row_per_measure():
    stat = {"mean": 1.0, "ci_low": 0.5, "ci_high": 1.5, "n": 3}
    scenario = {"name": "X", "source": "config", "n_scans": 3, "targets": ["a"],
                "trackers": {"t": {"runs": 3, "metrics": {m.key: stat for m in RUN_MEASURES}}}}
    table = scenario_table(scenario, {"trackers": {"t": {TIME.key: stat}}}, False, 0.95)
    assert [r[0] for r in table.rows] == [m.title for m in TRACK_MEASURES]
    assert table.rows[[m.key for m in TRACK_MEASURES].index("mota")][1] == "1.000 [0.500, 1.500]"


def test_one_entry_serves_every_kind_it_applies_to():
    rmse = measure("position_rmse_m")
    assert set(rmse.kinds) == {"track", "filter"} and rmse in RUN_MEASURES and rmse in FILTER_MEASURES
    assert [m.key for m in FILTER_MEASURES] == ["position_error_m", "position_rmse_m", "velocity_rmse_m_s", "nees",
                                                 "divergence_pct", "start_s"]
    assert TIME in for_kind("track") and TIME in for_kind("filter") and TIME not in FILTER_MEASURES
    assert all("filter" not in m.kinds or m in for_kind("filter") for m in MEASURES)
    assert for_kind("reentry") == ()
