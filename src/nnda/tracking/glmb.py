"""δ-GLMB tracker with the joint prediction-update and Gibbs sampling (Vo & Vo 2013; Vo, Vo & Hoang 2017),
the IMM of every contact tracker as single-target density.

    tracker = make_tracker("glmb", scenario.sensors, {"pd": 0.9, "max_hypotheses": 50})
    outputs = [tracker.step(scan) for scan in dataset.scans()]

**Density.** A mixture of hypotheses h, each a set of labelled tracks (a track: a label, the nnda track id,
and its association history, held as one IMM density) with a weight w_h. Tracks are shared: every
hypothesis indexes one table of tracks (``hyp`` (H, L): the track of each of the L live labels, -1 where
the label is absent), so the IMM predict and update run once per distinct track and history, in one batch.

**Joint prediction-update** (one scan). Every track s present in a hypothesis, with existence e_s (1 for a
track of the mixture, below 1 for a birth, `nnda.tracking.lmb` for the LMB's labels), has the options
(the columns of `nnda.tracking.gibbs`): it dies, weight 1 - p_S e; it survives and is missed,
p_S e (1 - P_D); it survives and takes a gated contact z, p_S e P_D l(z) / lambda_c(z) (l the IMM
likelihood of the prediction, lambda_c the clutter density in measurement space: the fixed
``clutter_density`` m^-2 or the local estimate (``clutter_estimate``: by default of the contacts the labels do not
explain, `nnda.tracking.labelled`), times the area Jacobian; a contact left to clutter weighs
1 relative). Per hypothesis the assignments of its tracks (a contact to one track at most) are drawn by
`gibbs_assignments` (``gibbs_samples`` draws) or, ``sampler = "exhaustive"``, all enumerated
(`all_assignments`: small problems only); each gives a child hypothesis of weight w_h times its weight.
Equal children are merged, the weights normalised, those below ``min_hypothesis_weight`` dropped, N-scan
pruning applied as in `nnda.tracking.pmbm` (the contact each label took ``n_scan`` scans back in the best
hypothesis becomes final; a label absent from a hypothesis, dead there, constrains nothing, so the
hypotheses where a target has ended stay beside those where its track coasts: `nnda.tracking.labelled.n_scan_agrees`)
and at most
``max_hypotheses`` kept (a `BoundWarning` the first time the cap bites, ``n_capped`` counts the scans).
The draws always include the contact-free start and its one-row neighbours (`gibbs_assignments`), so a
track of low existence keeps its miss beside its death; with ``min_hypothesis_weight`` above 0, the children
lighter than their parent's heaviest by 800 nats are left out before they are merged (they would be pruned,
and weigh nothing in a double's sum: with a thousand targets they are most of the draws). A miss child keeps
its track's posterior (predicted again from its last update); a label in no hypothesis is deleted.

**Birth: measurement-driven**, as `nnda.tracking.pmbm`'s: the contacts the best hypothesis left free pair
with the sensor's initiators inside the initiation window (`TwoPointInitiation`), each pair a new label
with the two-point start's state and existence r_B, the posterior probability that the pair is a target
rather than clutter (odds P_D beta_NT / rho_1 times P_D / (A_w rho_2): ``birth_rate`` per scan over the
coverage, rho_1 and rho_2 the clutter at the two contacts, A_w the window's area). As in the adaptive
birth of Reuter, Vo, Vo & Dietmayer (2014), a pair formed at scan k joins every hypothesis at scan k + 1
as a track of existence r_B, so the joint update decides its presence with the other tracks; the births of
one contact (paired with several initiators) exclude each other there, one target having made the contact
(the sampler's row groups).

**Tentative labels.** In dense clutter r_B is small (~1e-4 at 1,000 clutter a scan) and the births many (hundreds
a scan): in the mixture, each would multiply the hypotheses while its existence, a sum over at most
``max_hypotheses`` of them, could not grow. So a birth below ``admission_existence`` joins no hypothesis;
it is a tentative label, a Bernoulli updated alone (after the joint update, in one batch for all of them) on
the contacts the best hypothesis left free, as an LMB label of its own: with a = p_S r, its existence
becomes a (1 - P_D + sum_z P_D l(z) / lambda_c(z)) / (1 - a + a (1 - P_D + sum_z P_D l(z) / lambda_c(z))), its
track the heaviest of its miss (1 - P_D) and its gated contacts (P_D l(z) / lambda_c(z)); contacts are not
exclusive between tentative labels. A tentative label reaching ``admission_existence`` joins every
hypothesis at the next scan, as a birth does; one below ``min_tentative_existence`` is dropped. The
contact a tentative label takes opens no birth, even when the label is dropped in that scan (as in pmbm;
at 5,000 clutter points a scan in S6's coverage a third fewer births than if only the surviving labels'
contacts counted). ``admission_existence`` 0 puts every birth in the hypotheses at once.

**Output.** The tracks of the highest-weight hypothesis are reported with their estimate (the
prediction after a miss) and contact, by label, then the births waiting for the next scan and the tentative
labels (PRELIMINARY, their two-point start's or last estimate). A label is CONFIRMED once its existence (the summed
weights of the hypotheses holding it) reaches ``existence_threshold`` and stays so; before, PRELIMINARY.
A reported label that is deleted is reported once more as DELETED with its last estimate. The life
cycle's initiation window, v_max and ``max_tracks`` (live labels) apply; its confirmation rule, M/N counts
and sanity rules do not: status comes from existence alone, whatever ``lifecycle.confirmation`` says
(`ContactTracker.confirmation_rule` is "existence").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, ClassVar, Literal

import numba
import numpy as np
from pydantic import Field

from nnda.data.dataset import Scan
from nnda.tracking.gibbs import NEGLIGIBLE, all_assignments, gibbs_assignments
from nnda.tracking.labelled import GatedRows, LabelledConfig, LabelledMixture, LabelledTable, merged, normalised
from nnda.tracking.output import NO_CONTACT, TrackerOutput
from nnda.tracking.protocol import TrackerConfig
from nnda.tracking.reports import Phase
from nnda.tracking.tracker import ScanContacts


class GLMBConfig(LabelledConfig):
    """δ-GLMB settings (module docstring); probabilities per scan of the sensor."""

    max_hypotheses: Annotated[int, Field(ge=1, description="hypotheses kept, best weights first")] = 50
    n_scan: Annotated[int, Field(ge=1, description="N-scan pruning depth (scans of ambiguity kept)")] = 3
    gibbs_samples: Annotated[int, Field(ge=1, description="Gibbs draws per hypothesis and scan")] = 50
    sampler: Annotated[Literal["gibbs", "exhaustive"], Field(description="gibbs: sample the assignments; "
                                                             "exhaustive: enumerate them all (exponential: "
                                                             "tiny scenes and tests only)")] = "gibbs"
    seed: Annotated[int, Field(ge=0, description="seed of the Gibbs sampler's draws (reset with the "
                                                 "tracker)")] = 0
    existence_threshold: Annotated[float, Field(gt=0, lt=1, description="existence probability at which a "
                                                "label is confirmed")] = 0.99
    min_hypothesis_weight: Annotated[float, Field(ge=0, lt=1, description="hypotheses of lower normalised "
                                                  "weight are dropped")] = 1e-4


@dataclass(frozen=True)
class LabelledTracks(LabelledTable):
    """S tracks (a label and one association history; `LabelledTable`: ``r`` the existence each enters the
    next update with, ``hist`` NO_CONTACT also before the label's first contact) and ``group`` (S,) a birth's
    contact until its first update (births of one contact exclude each other; -1 for every other track)."""

    group: np.ndarray

    @property
    def contact(self) -> np.ndarray:
        """(S,) the contact taken in the last scan (NO_CONTACT: missed)."""
        return self.hist[:, -1]


class GLMBTracker(LabelledMixture):
    """IMM + δ-GLMB with joint prediction-update by Gibbs sampling (module docstring)."""

    name: ClassVar[str] = "glmb"
    config_type: ClassVar[type[TrackerConfig]] = GLMBConfig
    cap_field: ClassVar[str] = "max_hypotheses"
    hypotheses: ClassVar[str] = "hypotheses"

    def reset(self) -> None:
        super().reset()
        self.born: LabelledTracks | None = None  # births waiting for the next scan
        self.rng = np.random.default_rng(self.config.seed)

    @property
    def trk(self) -> LabelledTracks | None:
        """The tracks the hypotheses index (``table``)."""
        return self.table

    def _step(self, scan: Scan, phase: Phase) -> TrackerOutput:
        sc = self._checked(scan, phase)  # a sweep: this tracker takes no asynchronous reports
        if self.born is not None:
            self._admit()
        mixture, tentative = self._gated(sc)
        if mixture is not None:
            self._update(sc, mixture)
            self._prune(self.hyp, self.log_w)
            self._count_best(sc)
        used = self._used(sc)
        waiting, taken = ([], None) if tentative is None else self._tentative_update(sc, tentative, used)
        tent = [*waiting, *([] if self.tentative is None else [self.tentative])]  # the tentative labels updated
        born, contact = self._births(sc, used, taken, sum(len(t) for t in tent))
        if born is not None:
            x, P = self.filter.estimate(born.filt)
            hist = np.full((len(born), self.config.n_scan), NO_CONTACT, np.int64)
            hist[:, -1] = contact
            waiting.insert(0, LabelledTracks(born, self._birth_existence(born, contact, sc)[0], hist, x, P, contact))
        self.born = (waiting[0] if len(waiting) == 1 else LabelledTracks.concat(waiting)) if waiting else None
        out = self._report(scan.index, sc.time)
        self._collapse()
        return out

    def _collapse(self) -> None:
        """After the scan's report: nothing here (the LMB filter collapses the mixture, `nnda.tracking.lmb`)."""

    # ---------------------------------------------------------------------- births
    def _admit(self) -> None:
        """The waiting births of existence ``admission_existence`` or more join every hypothesis as new labels;
        the others become tentative labels."""
        born, self.born = self.born, None
        join = born.r >= self.config.admission_existence
        if not join.all():
            rest = born.kept(~join)
            self.tentative = rest if self.tentative is None else self.tentative.joined(rest)
            if not join.any():
                return
            born = born.take(np.flatnonzero(join))
        first = 0 if self.table is None else len(self.table)
        self.table = born if self.table is None else self.table.joined(born)
        self.hyp = np.column_stack([self.hyp, np.tile(first + np.arange(len(born)), (len(self.log_w), 1))])
        self.labels = np.concatenate([self.labels, born.tracks.track_id])

    def _tentative_update(self, scan: ScanContacts, g: GatedRows, used: np.ndarray
                          ) -> tuple[list[LabelledTracks], np.ndarray]:
        """The tentative labels, gated in ``g``, updated on the contacts not ``used``
        (`LabelledMixture._tentative_children`); returns those that reached ``admission_existence`` (as one
        table, or none), to join at the next scan, and the contact each label's child took (T,) (NO_CONTACT: its
        miss), which starts no birth whether the label lives on or not (as in `nnda.tracking.pmbm`); keeps the
        others of existence ``min_tentative_existence`` or more in ``tentative``."""
        k, ready, taken = self._tentative_children(scan, g, used)
        kids = None if k is None else LabelledTracks(k.tracks, k.r, k.hist, k.x, k.P, np.full(len(k), -1, np.int64))
        ready, self.tentative = self._sorted_tentative(kids, ready)
        return ([] if ready is None else [ready]), taken

    def _waiting(self) -> list[LabelledTracks]:
        """The births waiting for the next scan, then the tentative labels (reported PRELIMINARY with their
        two-point start or last estimate)."""
        return [t for t in (self.born, self.tentative) if t is not None]

    # ---------------------------------------------------------------------- joint prediction-update
    def _update(self, scan: ScanContacts, g: GatedRows) -> None:
        """Update every track, predicted and gated in ``g``, in one batch (`LabelledMixture._predict_update`),
        then each hypothesis's assignments (module docstring). The new track table: the S miss children (index
        s), then one child per gated pair."""
        cfg, old = self.config, self.table
        u = self._predict_update(scan, g)
        pl, pj, pd = u.pl, u.pj, u.pd
        alive = cfg.survival_probability * old.r
        die = -np.log1p(-alive)
        with np.errstate(divide="ignore"):
            miss = -np.log(alive * (1.0 - pd))
        cost = np.log(u.clutter) - np.log(alive[pl] * pd[pl]) - u.ll
        n = len(u.tracks)
        self.table = LabelledTracks(u.tracks, np.ones(n), u.hist, u.x, u.P, np.full(n, -1, np.int64))
        hyps, weights = [], []
        for h in range(len(self.log_w)):
            kids, log_gain = self._children(self.hyp[h], die, miss, old.group, pl, pj, cost)
            hyps.append(kids)
            weights.append(self.log_w[h] + log_gain)
        self.hyp, self.log_w = merged(np.concatenate(hyps), np.concatenate(weights))
        self.log_w = normalised(self.log_w)

    def _children(self, parents: np.ndarray, die: np.ndarray, miss: np.ndarray, group: np.ndarray, pl: np.ndarray,
                  pj: np.ndarray, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One hypothesis's children: its tracks ``parents`` (L,) (-1 absent), the tracks' death and miss costs
        and exclusive groups (S,), the gated pairs (track ``pl``, contact ``pj``, ``cost`` (P,)); the child
        track of each label (A, L) and each child's log weight over its parent (A,)."""
        table, pair, where = _options(parents, die, miss, pl, pj, cost)
        group = group[parents[where]]
        if self.config.sampler == "exhaustive":
            assign, log_gain = all_assignments(table, group)
        else:
            assign, log_gain = gibbs_assignments(table, self.config.gibbs_samples, int(self.rng.integers(2**32)),
                                                 group, NEGLIGIBLE if self.config.min_hypothesis_weight else None,
                                                 check=False)
        kids = _kids(assign, pair, parents, where)
        return kids, log_gain


@numba.njit(cache=True, nogil=True)
def _options(parents, die, miss, pl, pj, cost):
    """One hypothesis's assignment problem: for its tracks ``parents`` (L,) (-1 absent), in label order, the
    cost table (n, 2 + m) of `nnda.tracking.gibbs` (columns: death ``die``, miss ``miss`` (S,), then the m
    contacts gated to any of them, ascending, each pair's ``cost`` (P,) of gated track ``pl``, contact ``pj``),
    the child track of each entry (n, 2 + m) (a pair's S + its index; 0 elsewhere) and the labels present,
    ``where`` (n,). One compiled pass."""
    S = die.size
    where = np.flatnonzero(parents >= 0)
    n = where.size
    row_of = np.full(S, -1, np.int64)
    for i in range(n):
        row_of[parents[where[i]]] = i
    sel = np.flatnonzero(row_of[pl] >= 0)
    contacts = np.unique(pj[sel])
    table = np.full((n, 2 + contacts.size), np.inf)
    pair = np.zeros((n, 2 + contacts.size), np.int64)
    for i in range(n):
        table[i, 0], table[i, 1] = die[parents[where[i]]], miss[parents[where[i]]]
    for q in sel:
        c = 2 + np.searchsorted(contacts, pj[q])
        table[row_of[pl[q]], c] = cost[q]
        pair[row_of[pl[q]], c] = S + q
    return table, pair, where


@numba.njit(cache=True, nogil=True)
def _kids(assign, pair, parents, where):
    """The child track of each label (A, L) under each assignment ``assign`` (A, n) of the labels present
    (``where`` (n,) into ``parents`` (L,)): -1 where the label dies or is absent, its parent's miss child (the
    parent's own index: the miss children come first) where it is missed, the pair's child (``pair``
    (n, 2 + m), `_options`) where it takes a contact."""
    A, n = assign.shape
    kids = np.full((A, parents.size), -1, np.int64)
    for a in range(A):
        for i in range(n):
            c = assign[a, i]
            if c == 1:
                kids[a, where[i]] = parents[where[i]]
            elif c >= 2:
                kids[a, where[i]] = pair[i, c]
    return kids
