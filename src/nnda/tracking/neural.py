"""The proposed method: association by the trained MLP scorer (spec §8.2-§8.3, A8, A10).

Each scan, for all live tracks at once:

1. *gate*: a contact is a candidate for a track if it lies in the azimuth
   sector of the track's last contact or one of its two neighbours, and if
   reaching it from that contact needs a speed of 30..400 m/s
   (`nnda.models.features.candidate_pairs`, the gating used for training;
   on large scans it searches k-d trees within the speed gate's reach, so
   the work grows with the candidate pairs, not with tracks x contacts);
2. *score*: the pair features [ΔV, Δα, ΔT] of every candidate pair, from the
   track's last two contacts and the candidate
   (`nnda.models.features.pair_features`, the training code), go through the
   numpy scorer in one call per scan;
3. *select*: pairs scoring above ``threshold`` (default 0: the network says
   "target") are matched greedily by descending score (`greedy_matching`):
   the best pair of the scan is taken, its track and contact leave the
   game, and so on. So each track gets the highest-scoring candidate still
   free, each contact goes to at most one track, and when two tracks want
   the same contact the one that scores it higher wins and the other falls
   back to its next candidate above the threshold, if any (A10). With
   ``confirmed_first`` the confirmed tracks take their pick before the
   preliminary ones, as GNN and JPDA do (off by default: the spec's rule);
4. *filter*: the chosen contact updates the track's IMM, which smooths the
   output only: association never looks at it (spec §7.2).

Contacts left over go to initiation, as for every tracker.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, ClassVar

import numpy as np
from pydantic import Field

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, ModelError
from nnda.models.features import candidate_pairs, pair_features
from nnda.models.scorer import Scorer, load_model
from nnda.tracking.assignment import greedy_matching
from nnda.tracking.imm import IMMPrediction
from nnda.tracking.output import TrackStatus
from nnda.tracking.tracker import Association, Tracker, TrackerConfig, Tracks


class NeuralConfig(TrackerConfig):
    """Neural tracker settings: the model file and the decision threshold on its output."""

    model: Path = Field(description="trained model file (model.json) or a directory holding one")
    threshold: Annotated[float, Field(ge=-1.0, lt=1.0, description="a pair is a match if its score "
                                      "exceeds this (the scorer's outputs lie in (-1, 1))")] = 0.0
    confirmed_first: bool = Field(False, description="confirmed tracks choose before preliminary ones "
                                  "(as in GNN and JPDA); False: one greedy pass by score (spec A10)")


class NeuralTracker(Tracker):
    """IMM tracker whose associations are decided by the trained MLP scorer (the proposed method).

    The scorer is loaded once, at construction, from ``config.model``;
    a missing file, a foreign format or a model trained on another feature
    definition is refused with a ConfigError naming the field.
    """

    name: ClassVar[str] = "nn"
    config_type: ClassVar[type[TrackerConfig]] = NeuralConfig

    def __init__(self, sensor: Sensor, config: NeuralConfig) -> None:
        super().__init__(sensor, config)
        try:
            self.scorer: Scorer = load_model(self.config.model)
        except ModelError as exc:
            raise ConfigError(f"{self.name} tracker config, field 'model': {exc}") from None

    def _maintain(self, tracks: Tracks, pred: IMMPrediction, z: np.ndarray, xy: np.ndarray,
                  time: float) -> Association:
        contact = np.full(len(tracks), -1, np.int64)
        if len(z):
            track, cand = candidate_pairs(tracks.p2, tracks.t2, tracks.az2, xy, z[:, 1], time)
            if track.size:
                features = pair_features(tracks.p1[track], tracks.t1[track], tracks.p2[track],
                                         tracks.t2[track], xy[cand], time)
                score = self.scorer(features)
                match = score > self.config.threshold
                rank = score[match]
                if self.config.confirmed_first:  # scores lie in (-1, 1): +2 puts confirmed tracks first
                    rank = rank + 2.0 * (tracks.status[track[match]] == TrackStatus.CONFIRMED)
                chosen_track, chosen_contact = greedy_matching(track[match], cand[match], rank)
                contact[chosen_track] = chosen_contact
        return self.hard_update(pred, z, contact)
