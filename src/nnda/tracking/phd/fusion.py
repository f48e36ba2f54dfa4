"""Fusion of local GM-PHD filters at a central station: the harbour of Lima (2022), Ch. 4, done three ways.

Each radar runs its own GM-PHD (`GMPHDTracker` with the EKF on the CT model,
`CentralPHDConfig`) on its own scans only and sends its posterior intensity to
the centre; nothing is fed back. After every scan the centre takes each
local intensity at that scan's time (the sweeping radar's posterior, the
others' predicted without births: `GMPHDTracker.intensity_at`) and fuses:

- ``fusion-merge``: the thesis's rule (its eq. 1.6): the union of all local
  components, then the Mahalanobis merge once more. A ship both radars see
  carries about one unit of weight from each, so the fused intensity counts
  it about twice: ``tracker.cardinality.mean`` (the fused weight total)
  shows the double counting; the tracks reported (each fused component of
  weight >= the extraction threshold, once) hide it.
- ``fusion-aa``: arithmetic-average (AA) fusion, v = sum_s omega_s(x) v_s(x)
  (Li, Hlawatsch & Djuric 2019, "Cooperative PHD filtering with
  arithmetic-average fusion"; Li, Corchado & Sun 2019, IEEE TAES 55(5)), with
  the weights set by the fields of view: at a component's mean, omega_s is
  1 / (number of radars that cover it) for each radar that does and 0 for
  the others (1 / R each where none does), so a ship one radar cannot see
  keeps its whole weight and one both see is counted once. AA rather than
  generalised covariance intersection (GCI, the geometric mean): the AA of
  Gaussian mixtures is again a Gaussian mixture (exact, no approximation of
  a mixture's power), and it is conservative when one radar misses a target
  (by occlusion, as here): the GCI's product drives the fused intensity
  towards zero wherever either radar's is, which loses exactly the occluded
  ship the second radar is there to recover. The price: a ship one radar
  misses inside both fields of view keeps only half its weight, so
  ``fusion-aa`` reports fused components from weight 0.4.
- ``fusion-central`` (`CentralPHDTracker`): no local filters; one GM-PHD
  updated with both radars' scans in turn (the iterated corrector of
  `nnda.tracking.phd.tracker`), the centralised reference.

Labels: every local component carries its filter's label; the centre keeps
its own track ids. A fused group (the components merged into one) takes the
oldest centre id among its members (a member's id is that of the group it
joined at the last fusion), or a new one, so a ship handed from one radar's
filter to the other's keeps its id. The centre reports a fused component
of weight >= the fused extraction threshold once its id has been so after
``extraction_scans`` sweeps in a row of one sensor (each sensor's sweeps
counted apart), and from then on whenever it is
(`nnda.tracking.phd.extraction.persistent`). One
fusion costs a merge over the union of the local mixtures (at most R J_max
components).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor, sensor_tuple
from nnda.data.sensor import in_coverage
from nnda.filters.mixture import Mixture, cap, combine_groups, merge_groups
from nnda.filters.motion import POS
from nnda.tracking.output import CONFIRMED, NO_CONTACT, TrackerOutput
from nnda.tracking.phd.config import AAFusionConfig, CentralPHDConfig, FusionConfig
from nnda.tracking.phd.extraction import above, persistent
from nnda.tracking.phd.tracker import Cardinality, GMPHDTracker, sensor_detection
from nnda.tracking.tracker import TrackerConfig, checked_config, checked_scan


def coverage_shares(sensors: Sequence[Sensor], sensor: np.ndarray, means: np.ndarray) -> np.ndarray:
    """The AA fusion weight omega of each component (J,): ``sensor`` (J,) the index of the radar whose
    filter it comes from, ``means`` (J, n) its state [x, vx, y, vy, ...]. 1 / (radars covering the mean)
    if its own radar covers it, else 0; 1 / R where no radar does."""
    inside = np.array([in_coverage(s, means[:, 0], means[:, 2]) for s in sensors])  # (R, J)
    n = inside.sum(axis=0)
    own = inside[sensor, np.arange(len(sensor))]
    return np.where(n > 0, own / np.maximum(n, 1), 1.0 / len(sensors))


def fuse(union: Mixture, threshold: float, covariance: str = "candidate") -> tuple[Mixture, np.ndarray]:
    """The fused intensity of ``union`` (the local components, already weighted) and each component's group
    (J,): components whose positions lie within squared Mahalanobis distance ``threshold`` of a heavier one
    merge, each group moment-matched over the whole state. The distance is that of `merge` on the [x, y]
    marginals (two radars' filters agree on where a ship is sooner than on its turn rate) with twice each
    covariance: the difference of two independent estimates has covariance P_i + P_j, about 2 P_i."""
    at = np.array(POS)
    groups, leaders = merge_groups(Mixture(union.weights, union.means[:, at], 2.0 * union.covariances[:, at][:, :, at],
                                           union.labels), threshold, covariance)
    return combine_groups(union, groups, leaders), groups


class CentralPHDTracker(GMPHDTracker):
    """``fusion-central``: one GM-PHD (EKF, CT) updated with every radar's scans in turn, with the harbour's
    parameters (`CentralPHDConfig`): the centralised reference of the fusion trackers; on one radar, the
    local filter of `FusionTracker`."""

    name: ClassVar[str] = "fusion-central"
    config_type: ClassVar[type[TrackerConfig]] = CentralPHDConfig


class FusionTracker:
    """One local GM-PHD per sensor and a fusion centre (see the module docstring); subclasses choose the
    weights of the local components (`_weights`)."""

    name: ClassVar[str] = "fusion-merge"
    config_type: ClassVar[type[TrackerConfig]] = FusionConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: FusionConfig | None = None) -> None:
        self.sensors = sensor_tuple(sensors)
        self.config = cfg = checked_config(self, config)
        local = cfg.model_dump(exclude={"fused_extraction_threshold", "sensor_pd"})
        self.local = tuple(CentralPHDTracker(s, CentralPHDConfig(**{**local, "pd": pd}))
                           for s, pd in zip(self.sensors, sensor_detection(self.name, cfg, self.sensors),
                                            strict=True))
        for f, s in zip(self.local, self.sensors, strict=True):
            f.label = f"{self.name} (the local filter of sensor {s.name!r})"
        self.reset()

    def reset(self) -> None:
        """Forget the local filters, the centre's ids and the last time (the start of a run)."""
        bounds_hit: set[str] = set()  # a bound warns once per run of the fusion tracker, whichever filter it bit
        for f in self.local:
            f.reset()
            f._bounds_hit = bounds_hit
        self.last_time = -np.inf
        self.known_keys = np.empty(0, np.int64)  # (sensor, local label) keys of the last fusion, sorted
        self.known_ids = np.empty(0, np.int64)  # their centre ids
        self.next_id = 0
        self.fused = Mixture.empty(self.config.state_dim)
        self.cardinality: Cardinality | None = None
        # per sensor: the centre ids extracted after its last sweep and after how many of its sweeps in a row;
        # the ids confirmed so far (`nnda.tracking.phd.extraction.persistent`)
        self.extraction_streaks = [(np.empty(0, np.int64), np.empty(0, np.int64)) for _ in self.sensors]
        self.confirmed_labels = np.empty(0, np.int64)

    @property
    def n_dropped_components(self) -> int:
        """The local filters' predicted components left out of their updates by ``max_pairs`` since the last
        reset (`GMPHDTracker.n_dropped_components`)."""
        return sum(f.n_dropped_components for f in self.local)

    @property
    def n_dropped_pairs(self) -> int:
        """The candidate pairs those components would have formed."""
        return sum(f.n_dropped_pairs for f in self.local)

    def _weights(self, sensor: np.ndarray, union: Mixture) -> np.ndarray:
        """The fusion weight of each local component (J,): 1 for the union and merge."""
        return np.ones(len(union))

    def _ids(self, keys: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
        """Centre ids of the groups (G,), in greedy order (heaviest first): each group's oldest member id, or a
        new one (also for all but the first of the groups that would share one); remembers the members'."""
        pos = np.searchsorted(self.known_keys, keys)
        found = pos < len(self.known_keys)
        found[found] = self.known_keys[pos[found]] == keys[found]
        ids = np.full(n_groups, np.iinfo(np.int64).max)
        np.minimum.at(ids, groups[found], self.known_ids[pos[found]])
        first = np.zeros(n_groups, bool)
        first[np.unique(ids, return_index=True)[1]] = True  # a split: the heaviest group keeps the id
        new = (ids == np.iinfo(np.int64).max) | ~first
        ids[new] = np.arange(self.next_id, self.next_id + int(new.sum()))
        self.next_id += int(new.sum())
        order = np.argsort(keys)
        self.known_keys, self.known_ids = keys[order], ids[groups][order]
        return ids

    def step(self, scan: Scan) -> TrackerOutput:
        """Update the sweeping sensor's local filter with the scan, fuse every local intensity at its time
        and report the fused components of weight >= ``fused_extraction_threshold`` as confirmed tracks, of
        the centre ids once so after ``extraction_scans`` sweeps in a row of one sensor."""
        _, time = checked_scan(self.name, scan, self.last_time, self.sensors)
        cfg = self.config
        self.local[scan.sensor].step(Scan(scan.index, scan.time, scan.measurements, 0))
        parts = [f.intensity_at(time) for f in self.local]
        sensor = np.repeat(np.arange(len(parts)), [len(p) for p in parts])
        union = Mixture.concat(parts) if len(parts) > 1 else parts[0]
        union = Mixture(union.weights * self._weights(sensor, union), union.means, union.covariances,
                        union.labels * len(parts) + sensor)  # a key per (sensor, local label)
        fused, groups = fuse(union, cfg.merge_threshold, cfg.merge_covariance)
        fused = Mixture(fused.weights, fused.means, fused.covariances, self._ids(union.labels, groups, len(fused)))
        self.fused = fused = cap(fused, cfg.max_components)
        self.last_time = time
        shown = above(fused, cfg.fused_extraction_threshold)
        shown = shown[np.argsort(fused.labels[shown], kind="stable")]
        shown, self.extraction_streaks[scan.sensor], self.confirmed_labels = persistent(
            fused.labels, shown, self.extraction_streaks[scan.sensor], self.confirmed_labels, cfg.extraction_scans)
        self.cardinality = Cardinality(scan.index, time, float(fused.weights.sum()), None, None, len(shown))
        k = len(shown)
        return TrackerOutput(scan.index, time, fused.labels[shown], np.full(k, CONFIRMED, np.int8),
                             fused.means[shown, :4], fused.covariances[shown, :4, :4],
                             np.full(k, NO_CONTACT, np.int64))


class AAFusionTracker(FusionTracker):
    """Arithmetic-average fusion with field-of-view weights (see the module docstring)."""

    name: ClassVar[str] = "fusion-aa"
    config_type: ClassVar[type[TrackerConfig]] = AAFusionConfig

    def _weights(self, sensor, union):
        return coverage_shares(self.sensors, sensor, union.means)
