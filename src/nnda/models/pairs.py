"""Labelled training pairs from datasets (after Vargas Avila (2015)).

For every target, its *oracle* track history is the sequence of its own
contacts (detections whose ``target_id`` is the target). At every scan after
the target's second detection, missed scans included, every contact of the
scan that passes the gates (`nnda.models.features`) against the track's
last two contacts becomes a pair:

* label +1 if the contact is the target's own, -1 if it is clutter;
* a contact of *another* target is labelled -1 by default (it does not
  continue this track, which is what the association must learn), or left
  out with ``other_targets="drop"``. The 17 training presets hold one
  target each, so the choice only matters for multi-target datasets.

ΔT counts from the target's last detection. Defaults where the thesis is silent:

* a pair is formed only while the track would still be alive: at most
  ``max_missed`` = 3 consecutive missed scans (ΔT <= 4 scan periods), the
  longest gap of the thesis's gap tables and its proposed tracker's deletion rule;
* scans run to the target's last scan in the truth table (the end of the
  scenario for the training presets).

``history="true"`` replaces the measured track contacts P1 and P2 by the
target's true positions at those scans (the candidates stay measured): the
easier data model, kept to explain the accuracy gap with the
thesis, not for training the tracker's model.

``features`` picks the feature set (`nnda.models.feature_sets`). The
extended set ``imm-innovation-9`` runs the trackers' IMM
(`IMM.for_sensor`) along each target's history as a
tracker would: started from the target's first two contacts (two-point
start), predicted to every scan over the time since its last update, its
prediction giving the features of that scan's candidates, then updated with
the target's own contact if it has one (a missed scan is not an update).
After a gap longer than ``max_missed`` scans, when a tracker would have
deleted the track, the filter restarts from the contacts on either side of
the gap, as the kinematic features do. With ``history="true"`` the filter is fed
the true positions. The context set ``imm-context-14``
(`nnda.models.context`) adds, per scan, each pair's standing among its
target's candidates and among the other targets' oracle tracks that have
the same contact as a candidate.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Literal

import numpy as np

from nnda.data.dataset import Dataset, iter_datasets
from nnda.data.sensor import cart_to_polar
from nnda.errors import ConfigError, DatasetError
from nnda.filters.imm import IMM
from nnda.models.context import IMM_CONTEXT, with_context
from nnda.models.feature_sets import feature_set
from nnda.models.features import KINEMATIC, FeatureSet, pair_features, passes_gate, sector
from nnda.models.innovation import IMM_INNOVATION, innovation_features

History = Literal["measured", "true"]
#: the options of `extract_pairs` a model file records (metadata "pair_options"), to rebuild its pairs
PAIR_OPTIONS = ("history", "other_targets", "max_missed", "features")
OtherTargets = Literal["negative", "drop"]


def model_pair_options(metadata: dict, features: str) -> dict:
    """The `extract_pairs` options that rebuild a model's pairs: those its ``metadata`` records
    ("pair_options"), with the feature set always the model's own ``features`` (a model saved through
    the API records none)."""
    recorded = metadata.get("pair_options", {})
    options = {k: recorded[k] for k in PAIR_OPTIONS if k in recorded} if isinstance(recorded, dict) else {}
    return {**options, "features": features}


@dataclass(frozen=True)
class PairSet:
    """Labelled pairs; row arrays of shape (N,) unless stated.

    ``features`` (N, F), the columns of ``feature_set``; ``labels`` +1 (the
    track's own contact) or -1; ``dataset`` indexes ``names``; ``scan`` is
    the candidate's scan, ``target_id`` the track's target and
    ``contact_target`` the candidate's origin (-1 clutter), ``contact`` its
    row in its dataset's detections and ``track`` the track's key (the
    target id for oracle pairs, a tracker's track id for harvested ones,
    `nnda.tracking.harvest`).
    """

    features: np.ndarray
    labels: np.ndarray
    dataset: np.ndarray
    scan: np.ndarray
    target_id: np.ndarray
    contact_target: np.ndarray
    contact: np.ndarray
    track: np.ndarray
    names: tuple[str, ...]
    feature_set: FeatureSet = KINEMATIC

    def __len__(self) -> int:
        return len(self.labels)

    @property
    def n_positive(self) -> int:
        return int(np.count_nonzero(self.labels > 0))

    @property
    def n_clutter(self) -> int:
        return int(np.count_nonzero(self.contact_target < 0))

    @property
    def n_other_target(self) -> int:
        """Negative pairs whose candidate is another target's contact."""
        return int(np.count_nonzero((self.labels < 0) & (self.contact_target >= 0)))

    def subset(self, rows: np.ndarray) -> PairSet:
        """The pairs at ``rows`` (index or mask)."""
        return PairSet(*(getattr(self, f.name)[rows] for f in fields(self) if f.name not in _PER_SET),
                       names=self.names, feature_set=self.feature_set)


_PER_SET = ("names", "feature_set")


def _empty(names: tuple[str, ...], features: FeatureSet = KINEMATIC) -> PairSet:
    i32 = np.zeros(0, dtype=np.int32)
    return PairSet(np.zeros((0, features.size)), np.zeros(0, dtype=np.int8), i32, i32, i32, i32, i32, i32, names,
                   features)


def concatenate(parts: Iterable[PairSet], feature_set: FeatureSet = KINEMATIC) -> PairSet:
    """One pair set from several of the same feature set, renumbering the dataset indices; no parts: an
    empty set of ``feature_set``."""
    parts = list(parts)
    names: tuple[str, ...] = ()
    shifted = []
    for p in parts:
        shifted.append(p.dataset + len(names))
        names += p.names
    if not parts:
        return _empty((), feature_set)
    if len({p.feature_set for p in parts}) > 1:
        raise ConfigError(f"cannot concatenate pairs of feature sets {sorted({p.feature_set.name for p in parts})}")
    cat = {f.name: np.concatenate([getattr(p, f.name) for p in parts])
           for f in fields(PairSet) if f.name not in ("dataset", *_PER_SET)}
    return PairSet(dataset=np.concatenate(shifted).astype(np.int32), names=names, feature_set=parts[0].feature_set,
                   **cat)


def dataset_name(dataset: Dataset) -> str:
    """``<scenario>/run-<run>/seed-<seed>``: names a dataset's pairs."""
    return f"{dataset.scenario.name}/run-{dataset.run}/seed-{dataset.seed}"


def extract_pairs(
    dataset: Dataset, history: History = "measured", other_targets: OtherTargets = "negative",
    max_missed: int = 3, features: str = KINEMATIC.name,
) -> PairSet:
    """Gated, labelled pairs of every target of ``dataset`` along its oracle history (module docstring)."""
    fs = feature_set(features, "training pairs")
    if history not in ("measured", "true"):
        raise ConfigError(f"history must be 'measured' or 'true', got {history!r}")
    if other_targets not in ("negative", "drop"):
        raise ConfigError(f"other_targets must be 'negative' or 'drop', got {other_targets!r}")
    if max_missed < 0:
        raise ConfigError(f"max_missed must be >= 0, got {max_missed}")
    det, truth = dataset.detections, dataset.truth
    bounds = dataset.scan_bounds()
    xy = np.column_stack([det.x, det.y])
    det_sector = sector(det.azimuth)
    det_z = np.column_stack([det.range, det.azimuth])
    imm = IMM.for_sensor(dataset.scenario.sensor) if fs in (IMM_INNOVATION, IMM_CONTEXT) else None
    parts = []
    for tid in range(len(dataset.scenario.targets)):
        own = np.flatnonzero(det.target_id == tid)  # one per scan, in scan order
        if own.size < 2:
            continue
        last_scan = truth.scan[truth.target_id == tid].max()
        own_scan, own_time = det.scan[own], det.time[own]
        if history == "true":
            rows = np.flatnonzero(truth.target_id == tid)
            at = rows[np.searchsorted(truth.scan[rows], own_scan)]
            own_xy = np.column_stack([truth.x[at], truth.y[at]])
            own_z = np.column_stack(cart_to_polar(truth.x[at], truth.y[at]))
            own_sector = sector(own_z[:, 1])
        else:
            own_xy, own_z, own_sector = xy[own], det_z[own], det_sector[own]
        scans = np.arange(own_scan[1] + 1, last_scan + 1)
        j2 = np.searchsorted(own_scan, scans) - 1  # the track's last contact before each scan
        alive_track = scans - own_scan[j2] <= max_missed + 1
        scans, j2 = scans[alive_track], j2[alive_track]
        # every contact of every evaluated scan, repeated per scan
        start, stop = bounds[scans - 1], bounds[scans]
        counts = stop - start
        last = np.repeat(j2, counts)
        cand = np.arange(counts.sum()) + np.repeat(start - np.cumsum(counts) + counts, counts)
        gate = passes_gate(own_xy[last], own_time[last], own_sector[last],
                           xy[cand], det.time[cand], det_sector[cand])
        origin = det.target_id[cand]
        if other_targets == "drop":
            gate &= (origin < 0) | (origin == tid)
        last, cand, origin = last[gate], cand[gate], origin[gate]
        values = pair_features(own_xy[last - 1], own_time[last - 1], own_xy[last], own_time[last],
                               xy[cand], det.time[cand])
        if imm is not None:
            values = _along_history(imm, own_z, own_time, own_scan, det.scan[cand], det.time[cand], det_z[cand],
                                    values, max_missed)
        parts.append(PairSet(
            features=values,
            labels=np.where(origin == tid, 1, -1).astype(np.int8),
            dataset=np.zeros(cand.size, dtype=np.int32),
            scan=det.scan[cand].astype(np.int32),
            target_id=np.full(cand.size, tid, dtype=np.int32),
            contact_target=origin.astype(np.int32),
            contact=cand.astype(np.int32),
            track=np.full(cand.size, tid, dtype=np.int32),
            names=(), feature_set=fs,
        ))
    name = (dataset_name(dataset),)
    if not parts:
        return _empty(name, fs)
    merged = concatenate(parts)
    if fs is IMM_CONTEXT:  # every target's oracle track is a rival of the others at its scan
        key = merged.scan.astype(np.int64) * len(dataset.scenario.targets) + merged.track
        merged = replace(merged, features=with_context(merged.features, key, merged.contact))
    return replace(merged, dataset=np.zeros(len(merged), dtype=np.int32), names=name)


def _along_history(
    imm: IMM, own_z: np.ndarray, own_time: np.ndarray, own_scan: np.ndarray,
    pair_scan: np.ndarray, pair_time: np.ndarray, pair_z: np.ndarray, kinematic: np.ndarray, max_missed: int,
) -> np.ndarray:
    """Extended features (P, 9) of one target's pairs, running ``imm`` along its history (module docstring).

    ``own_z`` (J, 2) polar [m, rad], ``own_time`` (J,) s and ``own_scan``
    (J,) are the target's history; the P pairs, sorted by scan, have their
    candidate's scan, time and polar measurement and their kinematic features.
    """
    out = np.empty((len(pair_scan), IMM_INNOVATION.size))
    post, t_post, born = imm.initialise(own_z[:1], own_z[1:2], own_time[0], own_time[1]), own_time[1], own_time[0]
    j = 2  # the next own contact
    for scan in np.union1d(pair_scan, own_scan[2:]):
        own_here = j < len(own_scan) and own_scan[j] == scan
        if own_here and own_scan[j] - own_scan[j - 1] > max_missed + 1:  # a tracker would have lost it: restart
            post = imm.initialise(own_z[j - 1:j], own_z[j:j + 1], own_time[j - 1], own_time[j])
            t_post, born, j = own_time[j], own_time[j - 1], j + 1
            continue
        lo, hi = np.searchsorted(pair_scan, scan), np.searchsorted(pair_scan, scan, side="right")
        time = pair_time[lo] if hi > lo else own_time[j]
        pred = imm.predict(post, time - t_post)
        if hi > lo:
            out[lo:hi] = innovation_features(imm, pred, np.zeros(hi - lo, np.int64), pair_z[lo:hi],
                                             kinematic[lo:hi], np.full(hi - lo, time - born))
        if own_here:
            post, t_post, j = imm.update(pred, own_z[j:j + 1]), time, j + 1
    return out


def pairs_from_datasets(datasets: Iterable[Dataset], **options) -> PairSet:
    """Pairs of every dataset, concatenated; ``options`` go to `extract_pairs`."""
    return concatenate(extract_pairs(d, **options) for d in datasets)


def load_pairs(path: str | Path, **options) -> PairSet:
    """Pairs of the dataset or collection at ``path``; DatasetError if it yields none."""
    pairs = pairs_from_datasets(iter_datasets(path), **options)
    if len(pairs) == 0:
        raise DatasetError(f"{path}: no training pairs (no target has two detections followed by "
                           f"contacts inside the gates)")
    return pairs
