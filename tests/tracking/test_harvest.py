"""Pairs harvested from the neural tracker's runs (DAgger), the context features it computes, the recipe check."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.encounters import encounter_scenes
from nnda.data.generator import generate
from nnda.data.presets import resolve
from nnda.data.scenario import Clutter, Scenario, Segment, Target
from nnda.errors import ConfigError
from nnda.models.context import D2_COLUMN, IMM_CONTEXT, context_features
from nnda.models.experiment import fit
from nnda.models.innovation import IMM_INNOVATION
from nnda.models.pairs import concatenate, pairs_from_datasets
from nnda.models.scorer import save_model
from nnda.tracking.harvest import balanced, dagger_pairs, harvest_pairs, track_targets
from nnda.tracking.lifecycle import THESIS_LIFECYCLE, LifecycleConfig
from nnda.tracking.neural import NeuralConfig, NeuralTracker
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker
from nnda.tracking.single_hypothesis import hard_update
from tolerances import RTOL

THESIS = LifecycleConfig(**THESIS_LIFECYCLE)


def _crossing(clutter: int = 30, seed: int = 2):
    a = Target(name="east", x_m=-15_000.0, y_m=14_000.0, heading_deg=90.0, speed_m_s=150.0,
               segments=[Segment(duration_s=160.0)])
    b = Target(name="north", x_m=-3_000.0, y_m=2_000.0, heading_deg=0.0, speed_m_s=150.0,
               segments=[Segment(duration_s=160.0)])
    return generate(Scenario(name="crossing", duration_s=160.0, targets=[a, b], clutter=Clutter(count=clutter)),
                    seed=seed)


@pytest.fixture(scope="module")
def ctx_model(tmp_path_factory):
    """A 14-5-1 scorer on the context features, LM, on the training presets and 6 encounter scenes."""
    data = [generate(s, 0) for s in resolve("train")] + [generate(s, 0) for s in encounter_scenes(6, 0)]
    result = fit(pairs_from_datasets(data, features=IMM_CONTEXT.name), "lm", n_hidden=5, seed=0)
    return save_model(result.scorer, tmp_path_factory.mktemp("ctx") / "model.json")


def test_track_targets_by_majority():
    votes = np.array([[0, 3, 1], [2, 1, 1], [1, 1, 2], [0, 2, 2], [0, 0, 0]])  # clutter, target 0, target 1
    np.testing.assert_array_equal(track_targets(votes), [0, -1, 1, 0, -1])
    np.testing.assert_array_equal(track_targets(np.array([[1], [0]])), [-1, -1])  # no targets at all


class Planted(NeuralTracker):
    """The nn tracker, but at scan ``at`` the track using target 0's contact is given a clutter contact
    instead (a known mistake); every output is kept."""

    at, origin, rows = 0, None, None

    def reset(self):
        super().reset()
        self.outputs, self.victim = [], None

    def step(self, scan):
        self.outputs.append(super().step(scan))
        return self.outputs[-1]

    def associate(self, tracks, pred, scan):
        chosen = super().associate(tracks, pred, scan)
        if scan.index != self.at:
            return chosen
        origin = self.origin[self.rows[scan.index - 1] + np.maximum(chosen.contact, 0)]
        victim = np.flatnonzero((chosen.contact >= 0) & (origin == 0) & (tracks.status == TrackStatus.CONFIRMED))
        clutter = np.flatnonzero(self.origin[self.rows[scan.index - 1]:self.rows[scan.index]] < 0)
        assert victim.size and clutter.size
        contact = chosen.contact.copy()
        # the clutter contact nearest the target's, so that the track still gates the target afterwards
        near = np.hypot(*(scan.xy[clutter] - scan.xy[contact[victim[0]]]).T)
        contact[victim[0]] = clutter[np.argmin(near)]
        self.victim = int(tracks.track_id[victim[0]])
        return hard_update(scan.filter, pred, scan.z, contact)


def test_harvested_pairs_carry_the_truth_labels(ext_model_file):
    ds = _crossing()
    origin, bounds = ds.detections.target_id, ds.scan_bounds()
    # the M/N rule keeps the victim through its planted miss
    tracker = Planted(ds.scenario.sensor, NeuralConfig(model=ext_model_file, lifecycle=THESIS))
    tracker.at, tracker.origin, tracker.rows = 20, origin, bounds
    pairs = harvest_pairs(ds, tracker)
    assert tracker.harvest is None and len(pairs) and pairs.feature_set is IMM_INNOVATION
    # the planted mistake: the victim's output at scan 20 used a clutter contact ...
    out = tracker.outputs[19]
    assert origin[bounds[19] + out.contact[out.track_id == tracker.victim][0]] < 0
    # ... yet its next pairs are labelled by the target it follows: +1 on target 0's contact and nowhere else
    after = (pairs.track == tracker.victim) & (pairs.scan > 20) & (pairs.scan <= 25)
    assert after.any() and (pairs.target_id[after] == 0).all()
    np.testing.assert_array_equal(pairs.labels[after] == 1, pairs.contact_target[after] == 0)
    assert (pairs.labels[after] == 1).any()  # the target's contacts are among its candidates again
    # brute force: a pair's track target is the majority origin of the contacts the track used before that scan
    used: dict[int, list[int]] = {}
    before: dict[tuple[int, int], int] = {}
    for o in tracker.outputs:
        for tid in {int(t) for t in pairs.track[pairs.scan == o.scan]}:
            counts = np.bincount(np.array(used.get(tid, []), np.int64) + 1, minlength=3)
            best = int(np.argmax(counts[1:]))
            before[(o.scan, tid)] = best if counts[1 + best] > counts[0] else -1
        for tid, c in zip(o.track_id.tolist(), o.contact.tolist()):
            if c >= 0:
                used.setdefault(tid, []).append(int(origin[bounds[o.scan - 1] + c]))
    expected = np.array([before[(int(k), int(t))] for k, t in zip(pairs.scan, pairs.track)])
    np.testing.assert_array_equal(pairs.target_id, expected)
    np.testing.assert_array_equal(pairs.contact_target, origin[pairs.contact])
    np.testing.assert_array_equal(pairs.labels == 1, (pairs.contact_target == expected) & (expected >= 0))


def test_tracker_computes_the_context_of_each_scan(ctx_model):
    ds = _crossing(clutter=60)
    tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(ctx_model), "feature_set": IMM_CONTEXT.name})
    pairs = harvest_pairs(ds, tracker)
    assert pairs.features.shape[1] == IMM_CONTEXT.size
    for k in np.unique(pairs.scan)[::5]:
        at = pairs.scan == k
        np.testing.assert_allclose(pairs.features[at, IMM_INNOVATION.size:],
                                   context_features(pairs.track[at], pairs.contact[at],
                                                    pairs.features[at, D2_COLUMN]), rtol=RTOL)
    assert (pairs.features[:, IMM_INNOVATION.size + 3] > 0).any()  # contacts claimed by two tracks occur


def test_balanced_keeps_every_followed_track_and_as_many_others(ext_model_file):
    ds = _crossing(clutter=100)
    pairs = harvest_pairs(ds, make_tracker("nn", ds.scenario.sensor, {"model": str(ext_model_file)}))
    kept = balanced(pairs, np.random.default_rng(0))
    followed = int((pairs.target_id >= 0).sum())
    assert 0 < followed < (pairs.target_id < 0).sum()  # most harvested pairs belong to tracks on clutter
    assert (kept.target_id >= 0).sum() == followed and (kept.target_id < 0).sum() == followed
    assert kept.n_positive == pairs.n_positive
    again = balanced(pairs, np.random.default_rng(0))
    np.testing.assert_array_equal(kept.contact, again.contact)


def test_dagger_adds_harvested_pairs(ext_model_file, tmp_path):
    data = [_crossing(seed=4)]
    oracle = pairs_from_datasets(data, features=IMM_INNOVATION.name)
    seen = []

    def train(p):
        seen.append(len(p))
        return fit(p, "lm", n_hidden=3, seed=0).scorer

    pairs, rounds = dagger_pairs(data, oracle, {}, 2, tmp_path, train)
    assert len(seen) == 2 and seen[0] == len(oracle) and seen[1] == len(oracle) + rounds[0]["harvested"]
    assert len(pairs) == len(oracle) + sum(r["harvested"] for r in rounds)
    assert concatenate([oracle]).feature_set is pairs.feature_set
    assert dagger_pairs(data, oracle, {}, 0, tmp_path, train)[0] is oracle
    with pytest.raises(ConfigError, match="rounds"):
        dagger_pairs(data, oracle, {}, -1, tmp_path, train)


def test_tracker_refuses_another_recipe(ext_model_file):
    sensor = _crossing().scenario.sensor
    make_tracker("nn", sensor, {"model": str(ext_model_file), "recipe": {"encounters": 0, "dagger": 0}})
    with pytest.raises(ConfigError, match="recipe"):
        make_tracker("nn", sensor, {"model": str(ext_model_file), "recipe": {"dagger": 1}})
