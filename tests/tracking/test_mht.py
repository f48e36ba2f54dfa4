"""Track-oriented MHT: exact global hypothesis, bounded trees, score-based confirmation."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.study.metrics import run_metrics
from nnda.tracking import global_hypothesis as gh
from nnda.tracking.global_hypothesis import global_hypothesis
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.mht import MHTConfig, MHTTracker


@dataclass
class _Ids:
    track_id: np.ndarray


@dataclass
class FakeLeaves:
    """Just what the global hypothesis reads: family ids, contact history, scores."""

    tracks: _Ids
    hist: np.ndarray
    score: np.ndarray

    def __len__(self):
        return self.score.size


def brute_force(leaves: FakeLeaves) -> float:
    """Best total score over every compatible choice of at most one leaf per family."""
    fam = leaves.tracks.track_id
    options = [[None] + list(np.flatnonzero(fam == f)) for f in np.unique(fam)]
    best = 0.0
    for pick in itertools.product(*options):
        chosen = [p for p in pick if p is not None]
        used = [(c, leaves.hist[i, c]) for i in chosen for c in range(leaves.hist.shape[1]) if leaves.hist[i, c] >= 0]
        if len(used) == len(set(used)):
            best = max(best, sum(leaves.score[i] for i in chosen))
    return best


@pytest.mark.parametrize("seed", range(25))
def test_global_hypothesis_is_the_best_compatible_set(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 11))
    leaves = FakeLeaves(_Ids(rng.integers(0, 4, n)), rng.integers(-2, 3, (n, 3)), rng.normal(1.0, 3.0, n))
    tracker = MHTTracker(PRESETS["S1"].sensor)
    chosen = tracker._global_hypothesis(leaves)
    fam = leaves.tracks.track_id[chosen]
    assert np.unique(fam).size == fam.size  # one leaf per family at most
    used = [(c, leaves.hist[i, c]) for i in chosen for c in range(3) if leaves.hist[i, c] >= 0]
    assert len(used) == len(set(used))  # no shared contact
    assert leaves.score[chosen].sum() == pytest.approx(brute_force(leaves), abs=1e-9)


@pytest.mark.parametrize("seed", range(10))
def test_clusters_past_the_search_budget_go_to_the_binary_program(seed, monkeypatch):
    """With no node to spend, every cluster goes to HiGHS, which gives the same best sum as the search."""
    rng = np.random.default_rng(200 + seed)
    n = int(rng.integers(4, 16))
    leaves = FakeLeaves(_Ids(rng.integers(0, 5, n)), rng.integers(-2, 3, (n, 3)), rng.normal(1.0, 3.0, n))
    searched = global_hypothesis(leaves.tracks.track_id, leaves.hist, leaves.score, 5_000)[0]
    monkeypatch.setattr(gh, "SEARCH_NODES", 0)
    solved = global_hypothesis(leaves.tracks.track_id, leaves.hist, leaves.score, 5_000)[0]
    assert leaves.score[solved].sum() == pytest.approx(leaves.score[searched].sum(), abs=1e-9)
    assert leaves.score[searched].sum() == pytest.approx(brute_force(leaves), abs=1e-9)


def test_the_search_reports_the_clusters_it_gives_up_on():
    # two clusters: families 0 and 1 share contact 5, families 2 and 3 contact 6
    fam = np.array([0, 0, 1, 2, 3])
    rows, res = np.array([0, 1, 2, 3, 4]), np.array([0, 1, 0, 2, 2])
    score, cluster = np.array([3.0, 1.5, 2.0, 1.0, 4.0]), np.array([0, 0, 0, 1, 1])
    members = np.arange(5)
    chosen, hard = gh.searched(members, cluster, fam, rows, res, score, 100)
    assert chosen.tolist() == [1, 2, 4] and not hard.any()  # 1.5 + 2 beats 3 alone; 4 beats 1
    chosen, hard = gh.searched(members, cluster, fam, rows, res, score, 2)
    assert hard.tolist() == [True, True, True, False, False] and chosen.tolist() == [4]


def test_global_hypothesis_never_chooses_a_leaf_without_a_positive_score():
    # two families sharing contact 0 of the last scan: a cluster solved exactly, whatever its scores
    family, hist = np.array([7, 7, 9]), np.array([[-1, 0], [-1, 1], [-1, 0]])
    chosen, solved, greedy = global_hypothesis(family, hist, np.array([-1.0, 0.0, -0.5]), 5_000)
    assert chosen.size == 0 and (solved, greedy) == (1, 0)
    chosen, solved, greedy = global_hypothesis(family, hist, np.array([2.0, 0.0, 1.5]), 5_000)
    assert chosen.tolist() == [0] and (solved, greedy) == (1, 0)
    chosen, _, _ = global_hypothesis(family, hist, np.array([0.5, 0.0, 1.5]), 5_000)
    assert chosen.tolist() == [2]  # the leaf of score 0 could join it, but is never chosen


def test_hypothesis_tree_stays_within_its_bounds():
    # without the sanity rules, which would prune the branches to impossible speeds before the bound does
    sane_off = LifecycleConfig(confirmation="mn", max_speed_m_s=1e9, max_position_sd_m=None, coverage_deletion=False)
    cfg = MHTConfig(max_track_branches=2, max_hypotheses_per_track=4, n_scan=2, lifecycle=sane_off)
    ds = generate(PRESETS["train03"], seed=2)  # dense clutter: many branches to prune
    tracker = MHTTracker(ds.scenario.sensor, cfg)
    most = 0
    for scan in ds.scans():
        before = 0 if tracker.leaves is None else len(tracker.leaves)
        tracker.step(scan)
        leaves = tracker.leaves
        if leaves is None:
            continue
        _, per_family = np.unique(leaves.tracks.track_id, return_counts=True)
        assert per_family.max() <= 4
        assert leaves.hist.shape[1] == 2
        most = max(most, per_family.max())
        assert len(leaves) <= cfg.max_track_branches * before + len(tracker.initiation.contacts) + 10_000
    assert most == 4  # the bound is reached, so it is what limits the tree


def test_score_confirmation_confirms_the_targets():
    ds = generate(PRESETS["S4"], seed=1)
    tracker = MHTTracker(ds.scenario.sensor, MHTConfig(lifecycle=LifecycleConfig(confirmation="score")))
    m = run_metrics(ds, [tracker.step(s) for s in ds.scans()])
    assert m.confirmed_tracks - m.false_tracks == 4 and m.lost_targets == 0


@pytest.mark.parametrize("seed", range(10))
def test_greedy_global_hypothesis_is_compatible_and_never_beats_the_exact_one(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(3, 11))
    leaves = FakeLeaves(_Ids(rng.integers(0, 4, n)), rng.integers(-2, 3, (n, 3)), rng.normal(1.0, 3.0, n))
    greedy = MHTTracker(PRESETS["S1"].sensor, MHTConfig(max_exact_leaves=1))
    chosen = greedy._global_hypothesis(leaves)
    fam = leaves.tracks.track_id[chosen]
    assert np.unique(fam).size == fam.size
    used = [(c, leaves.hist[i, c]) for i in chosen for c in range(3) if leaves.hist[i, c] >= 0]
    assert len(used) == len(set(used))
    assert leaves.score[chosen].sum() <= brute_force(leaves) + 1e-9
    assert (leaves.score[chosen] > 0).all()


def new_families_on_kept_contacts(initiation_contacts: str) -> tuple[int, int]:
    """MHT with ``initiation_contacts`` on a dense-clutter scene: (families opened, those opened on a contact that a
    leaf of an older family kept after the same scan also took)."""
    ds = generate(PRESETS["train03"], seed=2)
    tracker = MHTTracker(ds.scenario.sensor, MHTConfig(initiation_contacts=initiation_contacts))
    opened = shared = 0
    for scan in ds.scans():
        old = set() if tracker.leaves is None else set(tracker.leaves.tracks.track_id.tolist())
        tracker.step(scan)
        if tracker.leaves is None:
            continue
        leaves = tracker.leaves
        new = ~np.isin(leaves.tracks.track_id, list(old))
        taken = leaves.hist[~new, -1]
        opened += int(new.sum())
        shared += int(np.isin(leaves.hist[new, -1], taken[taken >= 0]).sum())
    return opened, shared


def test_a_contact_a_kept_leaf_took_opens_no_family():
    """By default a contact that any leaf kept by the branching took starts no family of its own; with
    'unchosen' only the global hypothesis's contacts are withheld, so in dense clutter new families share
    contacts with other families' kept branches."""
    opened, shared = new_families_on_kept_contacts("untaken")
    assert opened > 100 and shared == 0
    opened, shared = new_families_on_kept_contacts("unchosen")
    assert opened > 100 and shared > 10
