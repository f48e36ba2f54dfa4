"""Fusion of local GM-PHD filters at a central station: the harbour of Lima (2022), Ch. 4, done four ways.

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
- ``fusion-gci``: generalised covariance intersection (Mahler 2000; Clark et al. 2010), the weighted
  geometric mean v = v_1^omega v_2^(1 - omega) of the local intensities (omega 0.5 by default), in the
  Gaussian-mixture form of Battistelli et al. (2013): one component per pair of local components whose
  positions are within the gate, each pair's weight, mean and covariance in closed form (`gci`), after
  approximating a mixture's power by its components' powers. It counts a ship both radars hold once, but
  at less than either weight (the overlap of two differently shaped Gaussians: a median 0.42 of the
  geometric mean of the weights on the harbour's ships, measured), so it reports fused components from
  weight 0.1; and it loses what one radar's intensity lacks: a ship outside that radar's coverage (unless
  ``outside_coverage="keep"`` passes such components unchanged) or hidden from it.
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
components); ``fusion-gci`` first forms the gated pairs of the local
components (a J_1 x J_2 position gate, then the pairs inside it).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor, sensor_tuple
from nnda.data.sensor import in_coverage
from nnda.errors import FilterError
from nnda.filters.mixture import Mixture, cap, combine_groups, merge_groups
from nnda.filters.motion import POS
from nnda.tracking.output import CONFIRMED, NO_CONTACT, TrackerOutput
from nnda.tracking.phd.config import AAFusionConfig, CentralPHDConfig, FusionConfig, GCIFusionConfig
from nnda.tracking.phd.extraction import above, coast_floor, coasting, default_coast_misses, persistent
from nnda.tracking.phd.tracker import Cardinality, GMPHDTracker, sensor_detection
from nnda.tracking.protocol import TrackerConfig, checked_config, checked_scan


def coverage_shares(sensors: Sequence[Sensor], sensor: np.ndarray, means: np.ndarray) -> np.ndarray:
    """The AA fusion weight omega of each component (J,): ``sensor`` (J,) the index of the radar whose
    filter it comes from, ``means`` (J, n) its state [x, vx, y, vy, ...]. 1 / (radars covering the mean)
    if its own radar covers it, else 0; 1 / R where no radar does."""
    inside = np.array([in_coverage(s, means[:, 0], means[:, 2]) for s in sensors])  # (R, J)
    n = inside.sum(axis=0)
    own = inside[sensor, np.arange(len(sensor))]
    return np.where(n > 0, own / np.maximum(n, 1), 1.0 / len(sensors))


def _inverse_and_logdet(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses (K, n, n) and log-determinants (K,) of SPD matrices P (K, n, n)."""
    inv = np.linalg.inv(P)
    return 0.5 * (inv + np.swapaxes(inv, -1, -2)), np.linalg.slogdet(P)[1]


def gci(a: Mixture, b: Mixture, omega: float, gate: float | None = None,
        prune_threshold: float = 0.0) -> tuple[Mixture, np.ndarray, np.ndarray]:
    """Generalised covariance intersection of two Gaussian-mixture intensities: v_a^omega v_b^(1 - omega)
    (0 < omega < 1), as a Gaussian mixture of one component per (i, j) pair (Battistelli et al. 2013's
    approximation): each mixture's power is taken component-wise, (sum w N)^omega ~ sum w^omega N^omega, exact
    for one component or well-separated ones, and N(x; m, P)^omega = kappa N(x; m, P / omega) with
    log kappa = (1 - omega) / 2 log det(2 pi P) - n / 2 log omega; the product of two Gaussians is
    N(x; m_i, A) N(x; m_j, B) = N(m_i; m_j, A + B) N(x; c, C), C = (A^-1 + B^-1)^-1, c = C (A^-1 m_i + B^-1 m_j).
    So pair (i, j) has weight w_i^omega w_j^(1 - omega) kappa_i kappa_j N(m_i; m_j, P_i / omega + P_j / (1 - omega)),
    covariance (omega P_i^-1 + (1 - omega) P_j^-1)^-1. The intensity of the fused Poisson process is this
    product itself, unnormalised (Clark et al. 2010): two identical components fuse to themselves.

    Only pairs whose [x, y] means lie within squared Mahalanobis distance ``gate`` (None: every pair) under
    that pair's position covariance P_i / omega + P_j / (1 - omega) are formed (beyond 50 the positions alone
    put a factor below e^-25 on its weight), and only those heavier than ``prune_threshold`` kept. Returns the fused
    mixture (labels: a's), and each component's i and j. Vectorised over the pairs."""
    if not 0.0 < omega < 1.0:
        raise FilterError(f"gci: the fusion weight omega must lie in (0, 1), got {omega} (config field omega)")
    n, w1, w2 = a.dim, omega, 1.0 - omega
    empty = np.empty(0, np.int64)
    if not len(a) or not len(b):
        return Mixture.empty(n), empty, empty
    at = np.array(POS)
    # the gate on the positions of every pair: 2 x 2 sums inverted in closed form
    S = a.covariances[:, at][:, :, at][:, None] / w1 + b.covariances[:, at][:, :, at][None] / w2  # (Ja, Jb, 2, 2)
    d = a.means[:, None, at] - b.means[None, :, at]  # (Ja, Jb, 2)
    det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
    d2 = (S[..., 1, 1] * d[..., 0] ** 2 - 2.0 * S[..., 0, 1] * d[..., 0] * d[..., 1]
          + S[..., 0, 0] * d[..., 1] ** 2) / det
    i, j = np.nonzero(d2 <= gate) if gate is not None else np.nonzero(np.ones(d2.shape, bool))
    if not len(i):
        return Mixture.empty(n), empty, empty
    Ia, la = _inverse_and_logdet(a.covariances)
    Ib, lb = _inverse_and_logdet(b.covariances)
    log_2pi = n * np.log(2.0 * np.pi)
    log_kappa_a = 0.5 * w2 * (la + log_2pi) - 0.5 * n * np.log(w1)
    log_kappa_b = 0.5 * w1 * (lb + log_2pi) - 0.5 * n * np.log(w2)
    info = w1 * Ia[i] + w2 * Ib[j]  # (K, n, n)
    C, _ = _inverse_and_logdet(info)
    c = np.einsum("kab,kb->ka", C, w1 * np.einsum("kab,kb->ka", Ia[i], a.means[i])
                  + w2 * np.einsum("kab,kb->ka", Ib[j], b.means[j]))
    Sf = a.covariances[i] / w1 + b.covariances[j] / w2
    diff = a.means[i] - b.means[j]
    maha = np.einsum("ka,ka->k", diff, np.linalg.solve(Sf, diff[..., None])[..., 0])
    log_norm = -0.5 * (maha + np.linalg.slogdet(Sf)[1] + log_2pi)
    with np.errstate(divide="ignore"):
        log_w = (w1 * np.log(a.weights[i]) + w2 * np.log(b.weights[j]) + log_kappa_a[i] + log_kappa_b[j]
                 + log_norm)
    weights = np.exp(log_w)
    keep = weights > prune_threshold
    fused = Mixture(weights[keep], c[keep], C[keep], a.labels[i[keep]])
    return fused, i[keep], j[keep]


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
        local = cfg.model_dump(exclude=set(type(cfg).model_fields) - set(CentralPHDConfig.model_fields) | {"sensor_pd"})
        #: the P_D of each sensor's scans and where it came from (each local filter's ``pd``)
        self.detection = sensor_detection(self.name, cfg, self.sensors)
        #: the misses in a row a reported centre id is shown through (`extraction.default_coast_misses`)
        self.coast_misses = default_coast_misses(cfg.coast_misses, len(self.sensors))
        self.local = tuple(CentralPHDTracker(s, CentralPHDConfig(**{**local, "pd": pd}))
                           for s, pd in zip(self.sensors, self.detection.values, strict=True))
        for f, s in zip(self.local, self.sensors, strict=True):
            f.label = f"{self.name} (the local filter of sensor {s.name!r})"
        self.reset()

    def reset(self) -> None:
        """Forget the local filters, the centre's ids and the last time (the start of a run)."""
        bounds_hit: set[str] = set()  # a bound warns once per run of the fusion tracker, whichever filter it bit
        for f in self.local:
            f.reset()
            f._bounds_hit = bounds_hit
        self.last_time, self.last_sensor = -np.inf, -1
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

    def _combined(self, parts: list[Mixture]) -> Mixture:
        """What the centre merges, from each local intensity at the scan's time: the union of their components,
        each weighted by `_weights`, labelled with a key per (sensor, local label)."""
        sensor = np.repeat(np.arange(len(parts)), [len(p) for p in parts])
        union = Mixture.concat(parts) if len(parts) > 1 else parts[0]
        return Mixture(union.weights * self._weights(sensor, union), union.means, union.covariances,
                       union.labels * len(parts) + sensor)

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
        _, time = checked_scan(self.name, scan, self.last_time, self.sensors, self.last_sensor)
        cfg = self.config
        self.local[scan.sensor].step(Scan(scan.index, scan.time, scan.measurements, 0))
        union = self._combined([f.intensity_at(time) for f in self.local])
        fused, groups = fuse(union, cfg.merge_threshold, cfg.merge_covariance)
        fused = Mixture(fused.weights, fused.means, fused.covariances, self._ids(union.labels, groups, len(fused)))
        self.fused = fused = cap(fused, cfg.max_components)
        self.last_time, self.last_sensor = time, scan.sensor
        shown = above(fused, cfg.fused_extraction_threshold)
        shown = shown[np.argsort(fused.labels[shown], kind="stable")]
        shown, self.extraction_streaks[scan.sensor], self.confirmed_labels = persistent(
            fused.labels, shown, self.extraction_streaks[scan.sensor], self.confirmed_labels, cfg.extraction_scans)
        if self.coast_misses:
            floor = coast_floor(cfg.fused_extraction_threshold, self.detection.values[scan.sensor], self.coast_misses)
            shown = coasting(fused.weights, fused.labels, shown, self.confirmed_labels, floor)
        self.cardinality = Cardinality(scan.index, time, float(fused.weights.sum()), None, None, len(shown))
        k = len(shown)
        return TrackerOutput(scan.index, time, fused.labels[shown], np.full(k, CONFIRMED, np.int8),
                             fused.means[shown, :4], fused.covariances[shown, :4, :4],
                             np.full(k, NO_CONTACT, np.int64))


class GCIFusionTracker(FusionTracker):
    """Generalised covariance intersection: the weighted geometric mean of the local intensities (`gci`; see
    the module docstring), the first sensor's with weight ``omega``, the others' sharing 1 - omega; more than
    two sensors are fused in turn (each step's weight the share of the sensors fused so far). With
    ``outside_coverage`` "keep", a component whose mean lies outside the coverage of the sensors it would be
    fused with passes unchanged (their intensities know nothing there); "drop": the plain geometric mean, which
    is zero wherever one sensor's intensity is."""

    name: ClassVar[str] = "fusion-gci"
    config_type: ClassVar[type[TrackerConfig]] = GCIFusionConfig

    def _combined(self, parts: list[Mixture]) -> Mixture:
        cfg, r = self.config, len(parts)
        omegas = [cfg.omega] + [(1.0 - cfg.omega) / (r - 1)] * (r - 1) if r > 1 else [1.0]
        keep = cfg.outside_coverage == "keep"
        fused = Mixture(parts[0].weights, parts[0].means, parts[0].covariances, parts[0].labels * r)
        done = omegas[0]
        for s in range(1, r):
            part = Mixture(parts[s].weights, parts[s].means, parts[s].covariances, parts[s].labels * r + s)
            # outside: a component the other side's sensors cannot see
            out_a = (~in_coverage(self.sensors[s], fused.means[:, 0], fused.means[:, 2]) if keep
                     else np.zeros(len(fused), bool))
            out_b = (~np.any([in_coverage(self.sensors[q], part.means[:, 0], part.means[:, 2]) for q in range(s)],
                             axis=0) if keep and len(part) else np.zeros(len(part), bool))
            both, _, _ = gci(fused.take(~out_a), part.take(~out_b), done / (done + omegas[s]), cfg.gate,
                             cfg.prune_threshold)
            fused = Mixture.concat([both, fused.take(out_a), part.take(out_b)])
            done += omegas[s]
        return fused  # keys: the first sensor's component of each pair, or the component passed


class AAFusionTracker(FusionTracker):
    """Arithmetic-average fusion with field-of-view weights (see the module docstring)."""

    name: ClassVar[str] = "fusion-aa"
    config_type: ClassVar[type[TrackerConfig]] = AAFusionConfig

    def _weights(self, sensor, union):
        return coverage_shares(self.sensors, sensor, union.means)
