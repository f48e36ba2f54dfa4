"""Training pairs harvested from the neural tracker's own runs, labelled by the truth (DAgger).

Oracle pairs (`nnda.models.pairs`) follow each target's own contacts, so the
network never sees the states a tracker reaches after its own mistakes, nor
tracks started on clutter. Here the tracker runs on a dataset with its
current model, and every (track, candidate) pair it scores is kept, with the
features it computed. The label comes from the dataset's truth, not from the
tracker's choice:

* a track's *target* is the target that gave most of the contacts it has
  used so far (the contact of its birth scan included; ties to the lower
  target id), or none if clutter gave at least as many (`track_targets`);
* a pair is +1 if its candidate is a contact of the track's target, -1
  otherwise (clutter, another target, or a track with no target).

So a track that took a wrong contact once is still labelled by the target it
follows, and the harvested set shows the network its own mistakes'
situations. `dagger_pairs` alternates training and harvest, keeping the
harvest's pairs of tracks with a target and as many of the others::

    pairs = harvest_pairs(dataset, tracker)          # PairSet of tracker.scorer.features
    pairs, counts = dagger_pairs(datasets, oracle, params, rounds=2, workdir=tmp, train=train)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from nnda.data.dataset import Dataset
from nnda.errors import ConfigError
from nnda.models.pairs import PairSet, concatenate, dataset_name
from nnda.models.scorer import Scorer, save_model
from nnda.tracking.neural import NeuralTracker
from nnda.tracking.registry import make_tracker


def track_targets(votes: np.ndarray) -> np.ndarray:
    """Each track's target from ``votes`` (K, 1 + T): column 0 counts its clutter contacts, column 1 + t
    those of target t. Returns (K,) target ids, -1 where no target gave more contacts than clutter."""
    best = np.argmax(votes[:, 1:], axis=1) if votes.shape[1] > 1 else np.zeros(len(votes), np.int64)
    most = votes[np.arange(len(votes)), 1 + best] if votes.shape[1] > 1 else np.zeros(len(votes))
    return np.where(most > votes[:, 0], best, -1)


def harvest_pairs(dataset: Dataset, tracker: NeuralTracker) -> PairSet:
    """Every pair ``tracker`` scores on ``dataset``, with its features and truth label (module docstring)."""
    bounds, origin = dataset.scan_bounds(), dataset.detections.target_id
    votes = np.zeros((0, 1 + len(dataset.scenario.targets)), np.int64)
    records: list[tuple] = []
    tracker.reset()
    tracker.harvest = lambda k, track_id, cand, features: records.append((k, track_id, cand, features))
    parts = []
    try:
        for scan in dataset.scans():
            n_before = len(records)
            out = tracker.step(scan)
            for k, track_id, cand, features in records[n_before:]:
                row = bounds[k - 1] + cand
                known = track_id < len(votes)  # a track scored before any contact was counted has no votes
                target = np.full(len(track_id), -1)
                target[known] = track_targets(votes[track_id[known]])
                parts.append(PairSet(
                    features=features, labels=np.where((origin[row] == target) & (target >= 0), 1, -1).astype(np.int8),
                    dataset=np.zeros(len(row), np.int32), scan=np.full(len(row), k, np.int32),
                    target_id=target.astype(np.int32), contact_target=origin[row].astype(np.int32),
                    contact=row.astype(np.int32), track=track_id.astype(np.int32), names=(),
                    feature_set=tracker.scorer.features))
            used = out.contact >= 0
            if used.any():
                ids = out.track_id[used]
                if ids.max() >= len(votes):
                    votes = np.vstack([votes, np.zeros((ids.max() + 1 - len(votes), votes.shape[1]), np.int64)])
                np.add.at(votes, (ids, 1 + origin[bounds[scan.index - 1] + out.contact[used]]), 1)
    finally:
        tracker.harvest = None
    name = (f"{dataset_name(dataset)}/harvest",)
    merged = concatenate(parts, tracker.scorer.features)
    if not parts:
        return replace(merged, names=name)
    return replace(merged, dataset=np.zeros(len(merged), np.int32), names=name)


def balanced(pairs: PairSet, rng: np.random.Generator, ratio: float = 1.0) -> PairSet:
    """Every harvested pair of a track with a target, and ``ratio`` times as many of the others (tracks
    started on clutter, all negatives) drawn without replacement, or all of them if fewer: in a tracker's run
    those are ~95 % of the pairs, and a least-squares fit to that balance scores almost every pair below 0."""
    if not ratio >= 0:
        raise ConfigError(f"the harvest's clutter-track ratio must be >= 0, got {ratio}")
    followed = pairs.target_id >= 0
    others = np.flatnonzero(~followed)
    keep = rng.choice(others, min(others.size, int(ratio * followed.sum())), replace=False)
    return pairs.subset(np.sort(np.concatenate([np.flatnonzero(followed), keep])))


def dagger_pairs(
    datasets: Sequence[Dataset], oracle: PairSet, params: dict, rounds: int, workdir: Path,
    train: Callable[[PairSet], Scorer], seed: int = 0, ratio: float = 1.0,
) -> tuple[PairSet, list[dict]]:
    """``rounds`` times: train on the pairs so far (``oracle`` at first), run the ``nn`` tracker (config
    ``params`` plus that model, saved under ``workdir``) on ``datasets`` and add the pairs it harvests,
    `balanced` by ``ratio`` (draws from ``SeedSequence([seed, round])``).

    ``train`` maps pairs to a scorer (seeded: same pairs, same scorer). Returns every pair (train the
    final model on them) and, per round, the counts of the pairs added.
    """
    if rounds < 0:
        raise ConfigError(f"dagger rounds must be >= 0, got {rounds}")
    pairs, summary = oracle, []
    for r in range(1, rounds + 1):
        path = save_model(train(pairs), workdir / f"dagger-round-{r}.json")
        harvested = concatenate((harvest_pairs(d, make_tracker("nn", d.scenario.sensors, {**params, "model": path}))
                                 for d in datasets), oracle.feature_set)
        harvested = balanced(harvested, np.random.default_rng(np.random.SeedSequence([seed, r])), ratio)
        pairs = concatenate([pairs, harvested])
        summary.append({"round": r, "harvested": len(harvested), "own_contact": harvested.n_positive,
                        "other_target": harvested.n_other_target, "clutter": harvested.n_clutter})
    return pairs, summary
