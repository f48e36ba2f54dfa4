"""Poisson multi-Bernoulli mixture (PMBM) tracker, track-oriented (Williams 2015; García-Fernández,
Williams, Granström & Svensson 2018), with the IMM of every contact tracker as single-target density.

    tracker = make_tracker("pmbm", scenario.sensors, {"pd": 0.9, "max_global_hypotheses": 100})
    outputs = [tracker.step(scan) for scan in dataset.scans()]

**Relation to** `nnda.tracking.mht`: this is a track-oriented MHT whose tracks (Bernoullis, one label each)
carry an existence probability r in every single-target hypothesis (STH), with the undetected targets as a
Poisson component, and whose global hypotheses are kept as a weighted mixture (the best
``max_global_hypotheses``, ranked by Murty's k-best assignment) instead of the single best set of leaves.
A miss multiplies an STH's weight by 1 - r P_D and sets r to r (1 - P_D) / (1 - r P_D); a detection
multiplies it by r P_D l(z) and sets r to 1 (l the IMM mixture likelihood of the contact); a contact
left to clutter weighs lambda_c(z), the clutter density in measurement space (fixed ``clutter_density``
m^-2, or the local estimate of the contacts the STHs do not explain, ``clutter_estimate``, `nnda.tracking.labelled`,
times the area Jacobian). Between scans r becomes
``survival_probability`` r. A scan:

1. predict and gate every STH in one batch (`IMM.predict`, `nnda.tracking.gating.gate`), the detection
   children updated in one batch (`nnda.tracking.linearisation.update`), the miss children keeping their
   posterior (predicted again from their last update);
2. per global hypothesis, the k best data associations of the scan, cluster by cluster (Bernoullis
   sharing gated contacts; `nnda.tracking.pmbm_hypotheses`), k = ceil(``max_global_hypotheses`` W_h);
   the new weights normalised;
3. pruning: an STH whose existence falls below ``min_existence`` is dropped (the Bernoulli absent in that
   global hypothesis), equal global hypotheses merged, those below ``min_hypothesis_weight`` dropped,
   N-scan pruning (the best hypothesis's assignment ``n_scan`` scans back becomes final:
   `nnda.tracking.labelled.n_scan_agrees`) and at most ``max_global_hypotheses`` kept (a `BoundWarning` the
   first time in a run, ``n_capped`` counts the scans); a Bernoulli absent from every global hypothesis is
   deleted;
4. the tentative Bernoullis updated (below); birth from the Poisson component (below), into every global
   hypothesis that leaves the contact free, of the new Bernoullis and the tentative ones that reached
   ``admission_existence``.

**Poisson component: measurement-driven.** A Gaussian mixture of undetected targets over a 2 s radar's
coverage (tens of km, speeds up to v_max in any direction) would need thousands of components to give a
new target's first contact a usable velocity; like the PHD trackers' adaptive birth
(`nnda.tracking.phd.birth`) the intensity is instead placed where contacts are, in the form the contact
trackers share: the contacts no Bernoulli took in the best global hypothesis are the Poisson's
measurements; each pairs with the initiators of the sensor's previous scan inside the initiation window
(`TwoPointInitiation`), and a pair opens a new Bernoulli with the two-point start's state. Its existence is
the posterior probability that the pair is a new target rather than clutter: odds P_D beta_NT / rho_1 (the
undetected targets' density beta_NT = ``birth_rate`` per scan over the coverage area, rho_1 the clutter at
the initiator) times P_D / (A_w rho_2) (the second contact anywhere in the window's area A_w, against the
clutter rho_2 there); in a global hypothesis where its contact is free it is present with that r and the
hypothesis's weight gains the factor 1 + odds (lambda_c + e over lambda_c), elsewhere it is absent. A
contact the best hypothesis gives to a Bernoulli opens none, as in the other contact trackers, and a
contact paired with several initiators opens a Bernoulli per pair (the initiation's rule; PMBM proper
opens one, its density a mixture over the pairs): both are the approximations of this formulation.

**Tentative Bernoullis.** A new Bernoulli whose existence is below ``admission_existence`` (in dense clutter
nearly all of them: ~1e-4 at 1,000 clutter a scan, hundreds a scan) joins no global hypothesis, where its
clusters would take the hypothesis budget from the targets' (the ``max_global_hypotheses`` best sums over
all clusters keep almost no alternatives of any one); it is a tentative label, updated alone on the contacts
the best global hypothesis leaves free, as `nnda.tracking.glmb` describes (its existence from its miss and
every gated contact, its STH the heaviest of them). Once its existence reaches ``admission_existence`` it
joins, in that scan, every global hypothesis leaving its last contact free, as a birth does with r its
existence; below ``min_tentative_existence`` it is dropped. The contacts the tentative labels take open no
Bernoulli. ``admission_existence`` 0 puts every new Bernoulli in the global hypotheses at once.

**Output.** The Bernoullis present in the highest-weight global hypothesis are reported with their STH's
estimate there (the prediction after a miss) and contact, by label (the track id, stable for the
Bernoulli's life), then the tentative labels (PRELIMINARY). A Bernoulli is CONFIRMED once its marginal
existence (r summed over the global hypotheses by weight) reaches ``existence_threshold`` and stays so;
before, it is reported PRELIMINARY. A confirmed Bernoulli whose existence has fallen below
``report_existence`` (0.5: after two missed scans in a row) is left out of the output until a contact raises
it again, and kept until ``min_existence`` prunes it: a track coasts through a gap of four scans without
showing a target's end for more than one scan.
A reported Bernoulli that is deleted is reported once more as DELETED with its last estimate. The life
cycle's initiation window, v_max and ``max_tracks`` (live Bernoullis) apply; its confirmation rule,
M/N counts and sanity rules do not: status comes from existence alone, whatever ``lifecycle.confirmation``
says (`ContactTracker.confirmation_rule` is "existence").
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

import numba
import numpy as np
from pydantic import Field, model_validator

from nnda.data.dataset import Scan
from nnda.tracking.exact import add_reduce
from nnda.tracking.labelled import GatedRows, LabelledConfig, LabelledMixture, LabelledTable, merged, normalised
from nnda.tracking.output import TrackerOutput
from nnda.tracking.pmbm_hypotheses import scan_hypotheses
from nnda.tracking.protocol import TrackerConfig
from nnda.tracking.reports import Phase
from nnda.tracking.tracker import ScanContacts

#: history entry of a scan before the Bernoulli existed (a miss is NO_CONTACT)
UNKNOWN = -2


class PMBMConfig(LabelledConfig):
    """PMBM settings (module docstring); probabilities per scan of the sensor."""

    clutter_estimate: Literal["local", "unexplained"] = Field(
        "local", description="the local estimate (clutter_density None): 'local', every contact in the square "
        "(itself included); 'unexplained', less the contact itself and the STHs' expected detections "
        "(`LabelledConfig`: MOTA 0.48 -> 0.70 at 1,000 aircraft, but in a clutter-free S6 a new label takes over "
        "a target after a miss, so not the default here)")

    @model_validator(mode="after")
    def _order(self) -> PMBMConfig:
        if self.min_existence >= self.existence_threshold:
            raise ValueError(f"min_existence = {self.min_existence:g} must be below existence_threshold = "
                             f"{self.existence_threshold:g}: a Bernoulli would be pruned before it is confirmed")
        return self

    birth_rate: Annotated[float, Field(gt=0, description="beta_NT: targets expected to appear per scan in the "
                                       "sensor's coverage (the Poisson birth intensity, uniform over it)")] = 0.5
    max_global_hypotheses: Annotated[int, Field(ge=1, description="global hypotheses kept, best weights "
                                                "first (at 50, S5's clutter pushed out the hypothesis that "
                                                "a target had been missed through its gap)")] = 100
    n_scan: Annotated[int, Field(ge=1, description="N-scan pruning depth (scans of ambiguity kept)")] = 3
    existence_threshold: Annotated[float, Field(gt=0, lt=1, description="marginal existence probability at "
                                                "which a Bernoulli is confirmed")] = 0.99
    min_existence: Annotated[float, Field(ge=0, lt=1, description="an STH of lower existence is dropped "
                                          "(its Bernoulli absent there): at 0.001, P_D 0.9 and p_S 0.99, a "
                                          "confirmed target is kept through four missed scans in a row and "
                                          "dropped at the fifth (reported through the first only: "
                                          "``report_existence``)")] = 0.001
    min_hypothesis_weight: Annotated[float, Field(ge=0, lt=1, description="global hypotheses of lower "
                                                  "normalised weight are dropped")] = 1e-4


class PMBMTracker(LabelledMixture):
    """IMM + track-oriented Poisson multi-Bernoulli mixture (module docstring). Its table (`LabelledTable`)
    holds the single-target hypotheses (STHs), ``hist`` UNKNOWN before a Bernoulli's birth."""

    name: ClassVar[str] = "pmbm"
    config_type: ClassVar[type[TrackerConfig]] = PMBMConfig
    cap_field: ClassVar[str] = "max_global_hypotheses"
    hypotheses: ClassVar[str] = "global hypotheses"

    @property
    def sth(self) -> LabelledTable | None:
        """The single-target hypotheses the global hypotheses index (``table``)."""
        return self.table

    # ---------------------------------------------------------------------- one scan
    def _step(self, scan: Scan, phase: Phase) -> TrackerOutput:
        sc = self._checked(scan, phase)  # a sweep: this tracker takes no asynchronous reports
        mixture, tentative = self._gated(sc)
        if mixture is not None:
            self._update(sc, mixture)
            self._prune_sths()
            self._count_best(sc)
        ready, taken, used = None, None, self._used(sc)
        if tentative is not None:
            kids, ready, taken = self._tentative_children(sc, tentative, used)
            ready, self.tentative = self._sorted_tentative(kids, ready)
        live = sum(len(t) for t in (ready, self.tentative) if t is not None)
        born, contact = self._births(sc, used, taken, live)
        if born is not None:
            r, log_odds = self._birth_existence(born, contact, sc)
            hist = np.full((len(born), self.config.n_scan), UNKNOWN, np.int64)
            hist[:, -1] = contact
            x, P = self.filter.estimate(born.filt)
            new = LabelledTable(born, r, hist, x, P)
            wait = r < self.config.admission_existence
            if wait.any():
                rest = new.kept(wait)
                self.tentative = rest if self.tentative is None else self.tentative.joined(rest)
            if not wait.all():
                self._birth(new.take(np.flatnonzero(~wait)), log_odds[~wait], len(sc.z))
        if ready is not None:
            self._birth(ready, np.log(ready.r) - np.log1p(-ready.r), len(sc.z))
        return self._report(scan.index, sc.time)

    # ---------------------------------------------------------------------- update
    def _update(self, scan: ScanContacts, g: GatedRows) -> None:
        """Update every STH, predicted and gated in ``g``, in one batch, then the k best associations of each
        global hypothesis (module docstring, steps 1-2)."""
        cfg, old = self.config, self.table
        S = len(old)
        u = self._predict_update(scan, g)
        pl, pj, pd = u.pl, u.pj, u.pd
        r = cfg.survival_probability * old.r
        log_miss = np.log1p(-r * pd)
        gain = np.log(r[pl] * pd[pl]) + u.ll - np.log(u.clutter) - log_miss[pl]
        r_miss = r * (1.0 - pd) / np.exp(log_miss)
        self.table = LabelledTable(u.tracks, np.concatenate([r_miss, np.ones(pl.size)]), u.hist, u.x, u.P)
        ks, missed = _asked(self.log_w, cfg.max_global_hypotheses, self.hyp, log_miss)
        self.hyp, gains, parent = scan_hypotheses(self.hyp, ks, pl, pj, S + np.arange(pl.size), gain)
        self.log_w = normalised((self.log_w + missed)[parent] + gains)

    # ---------------------------------------------------------------------- pruning
    def _prune_sths(self) -> None:
        """Step 3 of the module docstring: the STHs below ``min_existence`` dropped, equal global hypotheses
        merged, then `LabelledMixture._prune`."""
        self._prune(*merged(_floored(self.hyp, self.table.r, self.config.min_existence), self.log_w))

    # ---------------------------------------------------------------------- birth
    def _birth(self, new: LabelledTable, log_odds: np.ndarray, n_contacts: int) -> None:
        """New Bernoullis ``new`` (B rows, of this scan's contact ``new.hist[:, -1]``) with their existence's log
        odds (B,) added to every global hypothesis that leaves the contact free (module docstring); the scan
        has ``n_contacts`` contacts."""
        born, contact = new.tracks, new.hist[:, -1]
        first = 0 if self.table is None else len(self.table)
        self.table = new if self.table is None else self.table.joined(new)
        taken = np.zeros((len(self.log_w), n_contacts + 1), bool)  # contacts detected, per global hypothesis
        rows, cols = np.nonzero(self.hyp >= 0)
        if rows.size:
            last = self.table.hist[self.hyp[rows, cols], -1]
            taken[rows, last] = True  # a miss (-1) marks the spare last column
        free = ~taken[:, contact] | (contact < 0)  # (H, B); a tentative Bernoulli's miss takes nothing
        # C order kept: the compiled passes take the mixture in one layout (an F-ordered copy would compile, and
        # in a run load, a second version of each)
        self.hyp = np.ascontiguousarray(np.column_stack([self.hyp, np.where(free, first + np.arange(len(born)), -1)]))
        self.log_w = normalised(self.log_w + (free * np.logaddexp(0.0, log_odds)).sum(axis=1))
        self.labels = np.concatenate([self.labels, born.track_id])


@numba.njit(cache=True, nogil=True)
def _asked(log_w, most, hyp, log_miss):
    """Per global hypothesis of log weight ``log_w`` (H,) holding the STHs ``hyp`` (H, L) (-1 absent): the
    associations it asks for, k = ceil(``most`` W_h), at least 1, and its log weight when every Bernoulli
    is missed, the sum of its STHs' ``log_miss`` (S,) in label order (as numpy sums it, `exact.add_reduce`)."""
    H, L = hyp.shape
    ks = np.empty(H, np.int64)
    missed = np.empty(H)
    terms = np.empty(L)
    for h in range(H):
        ks[h] = max(1, math.ceil(most * math.exp(log_w[h])))
        n = 0
        for j in range(L):
            if hyp[h, j] >= 0:
                terms[n] = log_miss[hyp[h, j]]
                n += 1
        missed[h] = add_reduce(terms[:n])
    return ks, missed


@numba.njit(cache=True, nogil=True)
def _floored(hyp, r, least):
    """The global hypotheses ``hyp`` (H, L) without the STHs whose existence (``r`` (S,)) is below ``least``
    (-1 there, as for an absent Bernoulli): a copy."""
    out = hyp.copy()
    for h in range(hyp.shape[0]):
        for j in range(hyp.shape[1]):
            if hyp[h, j] >= 0 and not r[hyp[h, j]] >= least:
                out[h, j] = -1
    return out
