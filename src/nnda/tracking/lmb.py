"""Labelled multi-Bernoulli (LMB) filter (Reuter, Vo, Vo & Dietmayer 2014) on the δ-GLMB tracker's update.

    tracker = make_tracker("lmb", scenario.sensors, {"pd": 0.9})

The density between scans is one LMB: per label an existence r and one IMM density. A scan runs the
joint prediction-update of `nnda.tracking.glmb` (the same code) on the LMB taken as a single hypothesis
holding every label with its r (a label's death option then weighs 1 - p_S r: it may be absent), giving a
δ-GLMB of sampled hypotheses; the report is that GLMB's (its best hypothesis, existence marginals); then the
GLMB collapses to one LMB again: per label r = the summed weights of the hypotheses holding it, and the
density the track (association history) of the largest summed weight among them (the best, not the
moment-matched mixture: an IMM state is a mixture of models already). A label whose r falls below
``min_existence`` is deleted. Labels are the nnda track ids, births and tentative labels as in
`nnda.tracking.glmb`.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

import numpy as np
from pydantic import Field, model_validator

from nnda.tracking.glmb import GLMBConfig, GLMBTracker
from nnda.tracking.lookup import run_starts
from nnda.tracking.protocol import TrackerConfig


class LMBConfig(GLMBConfig):
    """LMB settings: the δ-GLMB's (`GLMBConfig`) and the existence below which a label is deleted."""

    min_existence: Annotated[float, Field(ge=0, lt=1, description="a label of lower existence is deleted")] = 1e-4

    @model_validator(mode="after")
    def _order(self) -> LMBConfig:
        if self.min_existence >= self.existence_threshold:
            raise ValueError(f"min_existence = {self.min_existence:g} must be below existence_threshold = "
                             f"{self.existence_threshold:g}: a label would be deleted before it is confirmed")
        return self


class LMBTracker(GLMBTracker):
    """IMM + LMB filter (module docstring)."""

    name: ClassVar[str] = "lmb"
    config_type: ClassVar[type[TrackerConfig]] = LMBConfig

    def _collapse(self) -> None:
        """The GLMB as one LMB (module docstring): one hypothesis, each label's best track with its r."""
        if self.table is None:
            return
        w = np.exp(self.log_w)
        rows, cols = np.nonzero(self.hyp >= 0)
        track = self.hyp[rows, cols]
        mass = np.bincount(track, weights=w[rows], minlength=len(self.table))  # (S,) summed weight of each track
        r = np.bincount(cols, weights=w[rows], minlength=self.labels.size)  # (L,)
        best = np.full(self.labels.size, -1, np.int64)
        order = np.lexsort((-mass[track], cols))  # by label, heaviest track first
        first = run_starts(cols[order])
        best[cols[order][first]] = track[order][first]
        kept = np.flatnonzero(r >= self.config.min_existence)  # the labels that live on, each with its best row
        self.hyp, self.log_w, self.labels = np.arange(kept.size)[None, :], np.zeros(1), self.labels[kept]
        self.table = self.table.take(best[kept]).replaced(r=np.minimum(r[kept], 1.0)) if kept.size else None
