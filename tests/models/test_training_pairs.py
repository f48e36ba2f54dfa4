from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nnda.data.dataset import write_dataset
from nnda.errors import ConfigError, DatasetError
from nnda.models.pairs import concatenate, extract_pairs, load_pairs

# target 0 flies north at 100 m/s from (0, 10 km): (0, 10_000 + 200 k) at scan k; scan 4 is missed
OWN = [(k, 0.0, 10_000.0 + 200 * k, 0) for k in (1, 2, 3, 5, 6)]
OTHERS = [
    (1, 300.0, 10_300.0, -1),   # before the track exists
    (2, 50.0, 10_450.0, -1),    # scan of the 2nd detection: not evaluated
    (3, 150.0, 10_500.0, -1),   # 90 m/s from P2: a clutter pair
    (3, 0.0, 10_420.0, -1),     # 10 m/s: below the speed gate
    (3, -9_000.0, -6_000.0, -1),  # far away, other sector
    (4, 0.0, 10_900.0, -1),     # missed scan: clutter pair, dT = 2 s
    (6, 100.0, 11_300.0, 1),    # the other target's only contact, close to target 0
]


@pytest.fixture
def hand(make_dataset):
    return make_dataset(OWN + OTHERS, n_scans=6, n_targets=2)


def rows(pairs):
    return sorted(zip(pairs.scan.tolist(), pairs.labels.tolist(), pairs.contact_target.tolist(),
                      np.round(pairs.features, 9).tolist()))


def test_labels_and_features_on_a_hand_made_dataset(hand):
    pairs = extract_pairs(hand)
    assert rows(pairs) == sorted([
        (3, 1, 0, [0.0, 0.0, 2.0]),
        (3, -1, -1, [round(np.hypot(150, 100) / 2 - 100, 9), round(np.degrees(np.arctan2(150, 100)) / 2, 9), 2.0]),
        (4, -1, -1, [50.0, 0.0, 2.0]),
        (5, 1, 0, [0.0, 0.0, 4.0]),
        (6, 1, 0, [0.0, 0.0, 2.0]),
        (6, -1, 1, [round(np.hypot(100, 300) / 2 - 100, 9), round(np.degrees(np.arctan2(100, 300)) / 2, 9), 2.0]),
    ])
    assert (pairs.n_positive, pairs.n_clutter, pairs.n_other_target) == (3, 2, 1)
    assert set(pairs.target_id.tolist()) == {0}  # target 1 never has two contacts
    assert pairs.names == ("hand/run-0/seed-0",)


def test_other_targets_can_be_dropped(hand):
    pairs = extract_pairs(hand, other_targets="drop")
    assert len(pairs) == 5 and pairs.n_other_target == 0


def test_pairs_stop_after_max_missed_scans(hand):
    pairs = extract_pairs(hand, max_missed=0)  # scan 5 comes 2 scans after the last detection
    assert 5 not in pairs.scan.tolist() and 4 in pairs.scan.tolist()


def test_true_history_uses_truth_positions_for_the_track(hand):
    shifted = replace(hand, truth=replace(hand.truth, x=hand.truth.x + 10.0))
    measured, true = extract_pairs(shifted), extract_pairs(shifted, history="true")
    assert len(true) == len(measured)
    own3 = true.features[(true.scan == 3) & (true.labels > 0)][0]
    # P1, P2 from truth (10 m east of the contacts), candidate measured
    assert own3[0] == pytest.approx(np.hypot(10, 200) / 2 - 100)
    assert own3[1] == pytest.approx(-np.degrees(np.arctan2(10, 200)) / 2)


def test_bad_options_are_refused(hand):
    with pytest.raises(ConfigError, match="history"):
        extract_pairs(hand, history="noisy")
    with pytest.raises(ConfigError, match="other_targets"):
        extract_pairs(hand, other_targets="positive")


def test_dataset_without_pairs_gives_a_clear_error(tmp_path, make_dataset):
    clutter_only = make_dataset([(k, 100.0 * k, 12_000.0, -1) for k in range(1, 5)], n_scans=4)
    assert len(extract_pairs(clutter_only)) == 0
    write_dataset(clutter_only, tmp_path / "empty")
    with pytest.raises(DatasetError, match="no training pairs"):
        load_pairs(tmp_path / "empty")


def test_concatenate_renumbers_datasets(hand):
    both = concatenate([extract_pairs(hand), extract_pairs(hand)])
    assert both.names == ("hand/run-0/seed-0",) * 2
    assert both.dataset.tolist() == [0] * 6 + [1] * 6


def test_training_presets_give_the_spec_sized_set(train_pairs):
    p = train_pairs
    # Vargas Avila (2015)'s training set: 868 target detections, at most 868 - 2 x 17 = 834 positives;
    # ~1935-1967 clutter
    assert 820 <= p.n_positive <= 834
    assert 1750 <= p.n_clutter <= 2200
    assert p.n_other_target == 0
    assert np.array_equal(p.labels > 0, p.contact_target == p.target_id)
    assert set(np.unique(p.features[:, 2]).tolist()) <= {2.0, 4.0, 6.0, 8.0}
    assert len(p.names) == 17
