"""The proposed method of Vargas Avila (2015), Sec. 5.3-5.5: association by the trained MLP scorer.

Each scan, for all live tracks at once:

1. *gate*: a contact is a candidate for a track if it lies in the azimuth
   sector of the track's last contact or one of its two neighbours, and if
   reaching it from that contact needs a speed of 30..400 m/s
   (`nnda.models.features.candidate_pairs`, the gating used for training:
   a compiled search of the contacts on a grid of the speed gate's reach,
   so the work grows with the candidate pairs, not with tracks x contacts);
2. *score*: the pair features of every candidate pair go through the numpy
   scorer in one call per scan. The features are those of the set the model
   was trained on (`nnda.models.feature_sets`), computed by the training
   code: the thesis's [ΔV, Δα, ΔT] (``kinematic-3``) from the track's last two contacts and the
   candidate (`nnda.models.features.pair_features`), and for
   ``imm-innovation-9`` also the track's IMM prediction read against the
   candidate (`nnda.models.innovation.innovation_features`: normalised
   innovation, Mahalanobis distance, log |S|, CT probability, track age),
   and for ``imm-context-14`` also each pair's standing among the scan's
   pairs (`nnda.models.context`: rank and d² margin among its track's
   candidates, their count, the other tracks that have the contact as a
   candidate and their least d²), from the same arrays in a few sorts. The
   gate and the first two feature sets take one compiled call a scan
   (`nnda.models.innovation.scan_features`, the training code's kernels);
3. *select* (the rules, and the scan's three compiled stages around them:
   `nnda.tracking.neural_matching`): pairs scoring above ``threshold``
   (default 0: the network says "target") are matched greedily by
   descending score (`greedy_matching`): the best pair of the scan is taken, its track and contact leave the
   game, and so on. So each track gets the highest-scoring candidate still
   free, each contact goes to at most one track, and when two tracks want
   the same contact the one that scores it higher wins and the other falls
   back to its next candidate above the threshold, if any (our reading: the
   thesis does not say how conflicts are settled). With
   ``confirmed_first`` the confirmed tracks take their pick before the
   preliminary ones, as GNN and JPDA do (off by default: the thesis's rule).
   With ``association = "global"`` the pairs above the threshold
   are instead assigned in one least-cost assignment per scan
   (`global_matching`): a pair costs the negative log-odds of its score
   (`nnda.models.scorer.score_log_odds`, p = (1 + s) / 2), and a track may
   miss at the cost of the threshold's log-odds (threshold 0: log-odds 0,
   p = 1/2; log-odds L is threshold tanh(L / 2)). So the scan's choice
   maximises the sum of the chosen pairs' log-odds above the threshold's,
   and a track whose best pick would block a better total yields it.
   ``confirmed_first`` then solves the confirmed tracks' assignment first and
   the preliminary tracks' on the contacts left;
   With ``coast_gate`` set, a confirmed track that has missed
   ``coast_after`` scans in a row or more and got no pair above the
   threshold takes, of the contacts still free in its chi-square gate (2
   dof) on the IMM's prediction, the one of least Mahalanobis d², as GNN
   would (`reacquire`). The network's domain ends where a coasting track's
   pairs leave the training pairs' (ΔT after a detection gap) or the
   candidate gate (a slow target far out, whose noisy step from its last
   contact looks slower than 30 m/s); the IMM's innovation, whose
   covariance grows while it coasts, still judges there, as in MHT and GNN.
   With it, the score rule (``lifecycle.confirmation = "score"``) deletes
   the tracks kept alive on clutter once their target has gone. Under
   ``confirmed_first`` the confirmed tracks pick and re-acquire before the
   preliminary ones choose among the contacts left, so a track just opened
   on a coasting track's target cannot take its contacts from it. With
   ``gate_after_miss`` a confirmed track that missed its last scan takes a
   network pick only inside that gate, so a clutter contact the network
   accepts after a gap cannot drag the track off its target. With
   ``association = "served"`` (needs ``coast_gate`` and ``confirmed_first``)
   the confirmed tracks' network pairs and their re-acquisition pairs go
   into one assignment (`served_matching`) that serves as many tracks as it
   can, as GNN does, and of those assignments takes the one of greatest
   log-odds: a track does not take, for a slightly better score, the only
   contact in a coasting neighbour's gate when it has another it accepts.
   With ``retrodiction`` a confirmed track that took a contact last scan
   and is left with none now goes back one scan: the track as it would be
   had it missed that scan, predicted to now, takes the nearest free
   contact in its gate, if there is one (`_retrodicted`). This is MHT's
   deferred decision kept to one scan and one alternative: one clutter
   contact inside the gate at a manoeuvre or in a detection gap pulls the
   filter so far that the target falls outside the gate a scan later.
   With ``preliminary_gate``, a preliminary track the network left without
   a pick takes, after every other pick of the scan, its nearest free
   contact inside that IMM gate, and the score rule weighs the contact: the
   young track of a turning or accelerating target, whose next contacts the
   network refuses (scores of -0.1 to -0.6 in S6, where clutter scores
   -1.0), would otherwise die and leave its target to a new start;
4. *filter*: the chosen contact updates the track's IMM. With the thesis's
   three features the filter smooths the output only (as in the thesis); with the
   extended set its prediction is also what the network reads.

Contacts left over go to initiation, as for every tracker.

**Sensors.** Any the contact trackers take: polar radars anywhere, position
sensors, several at once; a scan updates the tracks through its sensor's
IMM copy. The kinematic features are positions and times, whoever measured
them; the sector gate's two azimuths are both bearings from the position of
the sensor whose scan is associated (`_gate_azimuths`): the candidate's as
measured (polar) or of the fix from the sensor's position, and P2's of its
position from that same point, never two azimuths of different origins.
With one polar radar this is the training's rule, and P2's azimuth is read
as the radar measured it (the bearing without the polar-Cartesian round
trip's rounding): outputs bit for bit those of the one-radar tracker. A
pair needs time since the track's last contact (the speed gate refuses
ΔT = 0) and between its last two: a track whose last two contacts share an
instant (two sensors sweeping together) gets no network pair until a later
one, only the IMM's gates (``coast_gate``, ``preliminary_gate``). The IMM
feature sets read a polar radar's [range, azimuth] residuals: refused with
a position sensor.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from nnda.data.scenario import Sensor
from nnda.data.sensor import cart_to_polar_at
from nnda.errors import ConfigError, ModelError, TrackingError
from nnda.filters.imm import IMMPrediction
from nnda.models.context import IMM_CONTEXT, with_context
from nnda.models.feature_sets import FEATURE_SETS
from nnda.models.innovation import IMM_INNOVATION, scan_features
from nnda.models.scorer import Scorer, load_model
from nnda.tracking.assignment import given
from nnda.tracking.gating import Gated, gate, gate_tracks
from nnda.tracking.lookup import sorted_find
from nnda.tracking.neural_matching import RULES, first_stage, reacquire, reacquired, rest_stage, solved
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY
from nnda.tracking.protocol import TrackerConfig
from nnda.tracking.single_hypothesis import SingleHypothesisConfig, SingleHypothesisTracker, hard_update
from nnda.tracking.tracker import ScanContacts
from nnda.tracking.tracks import Association, Tracks

#: no gate pairs (the gate is off)
NO_PAIRS = Gated(np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0))
#: the recipe of a model whose metadata records none: oracle pairs of the training data alone
NO_RECIPE = {"encounters": 0, "dagger": 0}


def life4() -> dict:
    """The neural tracker's settings for coasting tracks that the measurements kept ("life4" in the
    record docs/records/2026-12-01-neural-association.md and studies/neural-ablation.toml; `life5` adds to
    them), as `NeuralConfig` fields (a new dict each call):
    a coasting confirmed track takes its nearest free contact in the IMM's 99 % gate, and after a miss a
    network pick only inside it; the confirmed tracks pick first, in one assignment with their
    re-acquisitions (``served``); the one-scan retrodiction; a track deleted in the scan it took a contact
    gives the contact back; the score rule with false_confirmation 1e-5 and false_deletion 5e-4."""
    return {"coast_gate": 9.21, "coast_after": 0, "confirmed_first": True, "gate_after_miss": True,
            "retrodiction": True, "association": "served", "release_on_deletion": True,
            "lifecycle": {"confirmation": "score", "false_confirmation": 1e-5, "false_deletion": 5e-4}}


def life5() -> dict:
    """`life4` with ``preliminary_gate`` 13.82 (the 99.9 % gate): a preliminary track the network leaves
    without a pick takes its nearest free contact in that gate (the demo's ``nn-life``)."""
    return {**life4(), "preliminary_gate": 13.82}


class NeuralConfig(SingleHypothesisConfig):
    """Neural tracker settings: the model file, the feature set expected of it, the decision threshold and
    the association rule."""

    model: Path = Field(description="trained model file (model.json) or a directory holding one")
    feature_set: Literal[tuple(FEATURE_SETS)] | None = Field(  # type: ignore[valid-type]
        None, description="the feature set the model must have been trained on; None: the model's own")
    threshold: Annotated[float, Field(ge=-1.0, lt=1.0, description="a pair is a match if its score "
                                      "exceeds this (the scorer's outputs lie in (-1, 1)); under "
                                      "association 'global' also a track's miss option, at the cost of "
                                      "this score's negative log-odds")] = 0.0
    confirmed_first: bool = Field(False, description="confirmed tracks choose before preliminary ones "
                                  "(as in GNN and JPDA); False: one pass over all tracks")
    recipe: dict[str, int | float] | None = Field(
        None, description="training recipe the model must record (metadata 'recipe' of `nnda train`, e.g. "
        "{ encounters = 60, dagger = 1 }; a model without one was trained with neither); None: any")
    association: Literal["greedy", "global", "served"] = Field(
        "greedy", description="'greedy': pairs taken by descending score; 'global': one least-cost "
        "assignment per scan, a pair costing the negative log-odds of its score, a miss the threshold's; "
        "'served': one assignment serving the most tracks, the confirmed ones also through the free contacts "
        "in their coast_gate, then of greatest log-odds (`served_matching`; needs coast_gate and "
        "confirmed_first)")
    coast_gate: Annotated[float | None, Field(
        gt=0, description="chi-square gate (2 dof; 9.21: P_G = 0.99) on the IMM's prediction within which a "
        "coasting confirmed track with no pair above the threshold takes its free contact of least Mahalanobis "
        "d²; None: off (the network decides alone)")] = None
    coast_after: Annotated[int, Field(
        ge=0, description="consecutive misses from which a confirmed track counts as coasting for "
                          "coast_gate (0: every confirmed track without a pick)")] = 1
    gate_after_miss: bool = Field(
        False, description="a confirmed track that missed its last scan takes a network pick only inside "
        "coast_gate (the IMM's gate, as MHT and GNN gate every pick): after a gap the network's candidates "
        "are pairs it rarely saw in training; needs coast_gate")
    retrodiction: bool = Field(
        False, description="a confirmed track left without a contact in the scan after one it took goes back "
        "one scan: if the track as it would be had it missed that scan has a free contact in its coast_gate "
        "now, it takes that branch and the nearest such contact (MHT's choice deferred by one scan, for one "
        "hypothesis); needs coast_gate")
    release_on_deletion: bool = Field(
        False, description="a track its life cycle or a sanity rule deletes in the scan it took a contact gives "
        "the contact back: it ends on a miss at its prediction, and the contact is free to start a track (a "
        "coasting track of a target that has gone takes clutter, and the score rule then ends it)")
    preliminary_gate: Annotated[float | None, Field(
        gt=0, description="chi-square gate (2 dof) on the IMM's prediction within which a preliminary track "
        "the network left without a pick takes its free contact of least Mahalanobis d², after every other "
        "pick of the scan (a manoeuvring target's young track, whose next contact the network refuses); the "
        "score rule then weighs the contact; None: off")] = None

    @model_validator(mode="after")
    def _needs_gate(self) -> NeuralConfig:
        for field in ("gate_after_miss", "retrodiction"):
            if getattr(self, field) and self.coast_gate is None:
                raise ValueError(f"{field} needs coast_gate (the gate it applies)")
        if self.association == "served" and (self.coast_gate is None or not self.confirmed_first):
            raise ValueError("association 'served' needs coast_gate (the confirmed tracks' gate) and "
                             "confirmed_first")
        return self


class NeuralTracker(SingleHypothesisTracker):
    """IMM tracker whose associations are decided by the trained MLP scorer (the proposed method).

    Built on any sensors a `ContactTracker` takes (polar radars, position sensors, several at once; the
    module docstring's *Sensors* says how the sector gate reads each). The scorer is loaded once, at
    construction, from ``config.model``;
    a missing file, a foreign format, a model trained on a feature
    definition this nnda does not compute, or on another set than
    ``config.feature_set``, or with another training recipe than
    ``config.recipe``, or of an IMM feature set with a position sensor, is refused with a ConfigError
    naming the field.
    """

    name: ClassVar[str] = "nn"
    config_type: ClassVar[type[TrackerConfig]] = NeuralConfig
    #: no P_D learnt from the tracks: a confirmed track's missing contact is as often the network refusing its
    #: target's contact as the radar missing it, so the record runs below the radar's P_D (0.72 for a true 0.8 on
    #: the manoeuvring scenes) and, measured, costs GOSPA (+7 m there and at 1,000 clutter points a scan)
    learns_pd = False

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: NeuralConfig) -> None:
        super().__init__(sensors, config)
        try:
            self.scorer: Scorer = load_model(self.config.model)
        except ModelError as exc:
            raise ConfigError(f"{self.name} tracker config, field 'model': {exc}") from None
        wanted, trained = self.config.feature_set, self.scorer.features.name
        if wanted is not None and wanted != trained:
            raise ConfigError(f"{self.name} tracker config, field 'model': {self.config.model} was trained on "
                              f"feature set {trained!r}, but this tracker is configured for {wanted!r} "
                              f"(field 'feature_set'); train a model on {wanted!r} or change the field")
        if self.config.recipe is not None:
            recorded = {**NO_RECIPE, **self.scorer.metadata.get("recipe", {})}
            wrong = {k: recorded.get(k) for k, v in self.config.recipe.items() if recorded.get(k) != v}
            if wrong:
                raise ConfigError(f"{self.name} tracker config, field 'model': {self.config.model} was trained "
                                  f"with recipe {wrong}, but field 'recipe' asks for "
                                  f"{ {k: self.config.recipe[k] for k in wrong} }; retrain it or change the field")
        self._extended = self.scorer.features in (IMM_INNOVATION, IMM_CONTEXT)
        self._context = self.scorer.features is IMM_CONTEXT
        fixes = [s.name for s in self.sensors if s.kind != "polar"]
        if self._extended and fixes:
            raise ConfigError(f"{self.name} tracker config, field 'model': {self.config.model} was trained on "
                              f"feature set {trained!r}, whose IMM columns are residuals in a polar radar's [range, "
                              f"azimuth], but sensor(s) {', '.join(fixes)} give position fixes; use a model of "
                              f"feature set 'kinematic-3' (nnda train --features kinematic-3) with these sensors")
        #: one polar radar: the sector gate reads the azimuths the radar measured (`_gate_azimuths`)
        self._one_radar = len(self.sensors) == 1 and not fixes
        self._rule = RULES[self.config.association]  # the code of the matching rule in the compiled stages
        #: if set, called each scan with (scan index, track id (P,), contact row (P,), features (P, F)) of
        #: every pair scored (`nnda.tracking.harvest`)
        self.harvest: Callable[[int, np.ndarray, np.ndarray, np.ndarray], None] | None = None

    def reset(self) -> None:
        super().reset()
        #: the last scan's tracks, contacts and sensor, for `_retrodicted`
        self._last_scan: tuple[Tracks, np.ndarray, int] | None = None

    def associate(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Association:
        """The scan's three stages (`nnda.tracking.neural_matching`), each a compiled pass, the retrodiction
        between the second and the third, then the chosen contacts' updates."""
        given = tracks  # the retrodiction may revise them (`_retrodicted`)
        contact = np.full(len(tracks), NO_CONTACT, np.int64)
        if not len(scan.z):
            self._last_scan = None
            return hard_update(scan.filter, pred, scan.z, contact)
        # the framework's arrays are checked already (scan checks, filter outputs): no second check here;
        # the scorer still refuses a non-finite feature
        cfg, n, consecutive = self.config, len(scan.z), tracks.consecutive
        track, cand, score = self._scored(tracks, pred, scan)
        g = self._gated(tracks, pred, scan)
        track, cand, score, first, problem = first_stage(
            track, cand, score, tracks.status, consecutive, n, cfg.gate_after_miss, cfg.confirmed_first,
            cfg.coast_after, self._rule, cfg.threshold, g.rows, g.cols, g.d2)
        rows, cols = solved(self._rule, cfg.threshold, *problem)
        contact[rows] = cols
        if cfg.coast_gate is not None:
            contact, lost = reacquired(contact, tracks.status, consecutive, CONFIRMED, cfg.coast_after, g.rows,
                                       g.cols, g.d2, cfg.coast_gate, n)
            if cfg.retrodiction:
                tracks, pred, contact = self._retrodicted(tracks, pred, scan, contact, lost)
        if cfg.confirmed_first:
            rows, cols = solved(self._rule, cfg.threshold,
                                *rest_stage(contact, first, track, cand, score, n, self._rule, cfg.threshold))
            contact[rows] = cols
        if cfg.preliminary_gate is not None:
            contact = self._preliminary_picks(tracks, g, scan, contact)
        if cfg.retrodiction:  # kept as they are; the branches are made only when the next scan asks
            self._last_scan = (tracks, contact, scan.sensor)
        assoc = hard_update(scan.filter, pred, scan.z, contact)
        return assoc if tracks is given else Association(assoc.contact, assoc.filt, revised=(tracks, pred))

    def _scored(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The scan's candidate pairs (track, cand) (P,) (`candidate_pairs`) and the scorer's output (P,) for
        them, on the model's feature set (`scan_features`: the candidates and the kinematic or the IMM-extended
        features in one call), less those of a track whose last two contacts share an instant (module docstring,
        *Sensors*)."""
        ext = self._extended
        az2, z = self._gate_azimuths(tracks, scan)
        track, cand, features = scan_features(
            scan.filter, pred, pred.gating.measurement if ext else None, tracks.p1, tracks.t1,
            tracks.p2, tracks.t2, az2, tracks.t0, scan.xy, z, scan.time, ext)
        if len(self.sensors) > 1:  # last two contacts of one instant (two sensors): no last speed or course
            timed = tracks.t1[track] < tracks.t2[track]
            if not timed.all():
                track, cand, features = track[timed], cand[timed], features[timed]
        if not track.size:
            return track, cand, np.empty(0)
        if self._context:
            features = with_context(features, track, cand)
        if self.harvest is not None:
            self.harvest(scan.index, tracks.track_id[track], cand, features)
        score = self.scorer(features)
        if not np.isfinite(score).all():  # NaN never beats the threshold: it would track nothing silently
            raise TrackingError(f"{self.name}: scan {scan.index}: the model {self.config.model} scored "
                                f"{int((~np.isfinite(score)).sum())} of {score.size} pairs as NaN; its "
                                f"weights or normaliser are broken: retrain it")
        return track, cand, score

    def _gate_azimuths(self, tracks: Tracks, scan: ScanContacts) -> tuple[np.ndarray, np.ndarray]:
        """The sector gate's azimuths (rad clockwise from north), all from the position of the scan's sensor
        (module docstring, *Sensors*): the tracks' last contacts' (K,), and the scan's contacts as
        [range m, azimuth rad] (N, 2) from there, as `scan_features` reads them.

        One polar radar: the stored azimuths of the last contacts and the scan's measurements, as the radar
        measured them. Otherwise P2's bearing is computed from its position (it may come from another
        sensor); a polar scan's contacts are its measurements, a position sensor's fixes are converted to
        range and bearing from the sensor's position (read for the gate only: the kinematic features use
        ``scan.xy``, and no IMM feature set runs with a position sensor)."""
        if self._one_radar:
            return tracks.az2, scan.z
        origin = self.sensors[scan.sensor].position
        az2 = cart_to_polar_at(origin, tracks.p2[:, 0], tracks.p2[:, 1])[1]
        if scan.filter.polar:
            return az2, scan.z
        return az2, np.column_stack(cart_to_polar_at(origin, scan.xy[:, 0], scan.xy[:, 1]))

    def _retrodicted(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts, contact: np.ndarray,
                     lost: np.ndarray) -> tuple[Tracks, IMMPrediction, np.ndarray]:
        """The retrodiction (``retrodiction``): the confirmed tracks ``lost`` (rows, ascending) that took a
        contact last scan and have none in ``contact`` (K,) now (`reacquired`), replaced by their branch
        without that contact (`_skipping`) where the branch's prediction has free contacts in its gate of
        ``coast_gate``, each with the nearest of them (`reacquire`). Returns the revised (tracks, prediction,
        contact): the same objects when no track goes back."""
        unchanged = tracks, pred, contact
        if self._last_scan is None or not lost.size or not len(self._last_scan[0]):
            return unchanged
        last, last_contact, last_sensor = self._last_scan
        # track ids ascend in both (tracks keep their order; new ones come last, with higher ids)
        ids = tracks.track_id[lost]
        at, found = sorted_find(last.track_id, ids)
        known = found & (last_contact[at] != NO_CONTACT) & (last.status[at] == CONFIRMED)
        lost, at = lost[known], at[known]
        if not lost.size:
            return unchanged
        branch = self._skipping(last.take(at), last_sensor)
        alive = branch.status != DELETED
        if not alive.all():
            lost, branch = lost[alive], branch.take(alive)
            if not lost.size:
                return unchanged
        branch_pred = scan.filter.predict(branch.filt, scan.time - branch.t2, check=False)
        g = gate_tracks(scan.filter, branch_pred, scan.z, scan.xy, self.config.coast_gate, check=False)[1]
        rows, cols = reacquire(g.rows, g.cols, g.d2, np.ones(lost.size, bool), given(contact, len(scan.z)),
                               self.config.coast_gate)
        if not rows.size:
            return unchanged
        index = np.arange(len(tracks))
        index[lost[rows]] = len(tracks) + rows
        contact = contact.copy()
        contact[lost[rows]] = cols
        return tracks.joined(branch).take(index), IMMPrediction.concat([pred, branch_pred]).take(index), contact

    def _skipping(self, tracks: Tracks, sensor: int) -> Tracks:
        """Last scan's confirmed ``tracks`` (K,), each of which took a contact then from ``sensor`` (an index),
        as they would be had they missed it instead (the branches of `_retrodicted`): their last posterior kept,
        the miss counted in their life cycle and score (a branch may come out deleted)."""
        K = len(tracks)
        gain = None if self.confirmation_rule == "mn" else np.full(K, self._log_miss(sensor))
        none = np.empty((0, 2))  # a miss reads no contact
        return tracks.after_scan(np.full(K, NO_CONTACT), tracks.filt, none, none, np.nan, self.config.lifecycle,
                                 None, gain)

    def _preliminary_picks(self, tracks: Tracks, g: Gated, scan: ScanContacts, contact: np.ndarray) -> np.ndarray:
        """``contact`` (K,) with the picks of the preliminary tracks still without one: the nearest free
        contact inside their IMM gate of ``preliminary_gate`` (their pairs of ``g``, `reacquired`)."""
        return reacquired(contact, tracks.status, tracks.consecutive, PRELIMINARY, 0, g.rows, g.cols, g.d2,
                          self.config.preliminary_gate, len(scan.z))[0]

    def _gated(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Gated:
        """The pairs inside the IMM gates this scan (`gate` on ``pred.gating``; rows index ``tracks``): the
        confirmed tracks' of ``coast_gate`` and the preliminary tracks' of ``preliminary_gate``, each when
        set (none when neither is), in one call: the clutter's preliminary tracks outnumber the confirmed
        ones, and only ``preliminary_gate`` asks for theirs."""
        cfg, status = self.config, tracks.status
        if cfg.preliminary_gate is None:
            if cfg.coast_gate is None:
                return NO_PAIRS
            rows, threshold = np.flatnonzero(status == CONFIRMED), cfg.coast_gate
        elif cfg.coast_gate is None:
            rows, threshold = np.flatnonzero(status == PRELIMINARY), cfg.preliminary_gate
        else:
            rows = None  # every track, each at its own gate
            threshold = np.where(status == CONFIRMED, cfg.coast_gate, cfg.preliminary_gate)
        g = pred.gating
        return gate(scan.filter, g.measurement, scan.z, scan.xy, threshold, (g.x, g.P), rows=rows, check=False)
