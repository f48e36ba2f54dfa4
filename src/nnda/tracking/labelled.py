"""A mixture of global hypotheses over labelled tracks: what the labelled RFS trackers share
(`nnda.tracking.pmbm`, `nnda.tracking.glmb` and, through the latter, `nnda.tracking.lmb`).

    class PMBMTracker(LabelledMixture): ...

**The mixture.** ``table`` (a `LabelledTable`, S rows) holds the tracks the hypotheses index: one row per
label and association history, with its existence and the estimate reported for the last scan. ``labels``
(L,) are the live labels (nnda track ids), ``hyp`` (H, L) the row of each label in each global hypothesis
(-1 where the label is absent) and ``log_w`` (H,) the hypotheses' normalised log weights.

**Shared here.** The first config fields (`LabelledConfig`), one scan's prediction, gating and children
(`LabelledMixture._predict_update`: a miss child per row, a detection child per gated pair, in one batch), the
clutter density at the contacts (``clutter_estimate`` "unexplained", glmb and lmb's default: the local count less each
contact itself and the rows' expected detections, P_G p_S r P_D weighted by the hypotheses holding them, at
their predicted positions, `nnda.tracking.clutter_density.unexplained_density`), the existence of a two-point
start (odds P_D beta_NT / rho_1 times P_D / (A_w rho_2), the pmbm module docstring), the births' free contacts
(those no label took in the best hypothesis),
the tentative labels (births below ``admission_existence``, each updated alone on the free contacts:
`LabelledMixture._tentative_children`, the glmb module docstring), the pruning (light hypotheses dropped,
N-scan pruning (`n_scan_agrees`), the cap, the rows and labels no hypothesis holds removed, in one
compiled pass `_pruned`), the existence marginals, and the report of the best hypothesis with the confirmed
/ DELETED bookkeeping, a confirmed label left out while its existence is below ``report_existence`` (a tracker
may report more rows after it: `LabelledMixture._waiting`, the tentative labels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, ClassVar, Literal, Self

import numba
import numpy as np
from pydantic import Field, model_validator

from nnda.filters import imm_kernels
from nnda.filters.batch import Batch
from nnda.filters.imm import IMMPrediction, IMMState
from nnda.filters.kalman import gate_probability
from nnda.tracking.clutter_density import coverage_area, local_density
from nnda.tracking.exact import add_reduce, logaddexp
from nnda.tracking.gating import gate
from nnda.tracking.gibbs import row_order, run_heads
from nnda.tracking.lifecycle import birth_log_odds, start_score
from nnda.tracking.linearisation import LINEARISATION_LIMIT_RAD, poor_rows
from nnda.tracking.lookup import among, members
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY, TrackerOutput
from nnda.tracking.phd.tracker import Cardinality
from nnda.tracking.tracker import ContactTracker, ContactTrackerConfig, ScanContacts
from nnda.tracking.tracks import T2, Tracks, branched_moved, branching_args, table_rows, tables_joined


class LabelledConfig(ContactTrackerConfig):
    """The settings every labelled RFS tracker has (the first of its config's fields); probabilities per scan
    of the sensor."""

    pd: Annotated[float, Field(gt=0, le=1, description="P_D, probability that a target is detected in a scan")] = 0.9
    survival_probability: Annotated[float, Field(gt=0, lt=1, description="p_S, probability that a target "
                                                 "exists still at the next scan")] = 0.99
    birth_rate: Annotated[float, Field(gt=0, description="beta_NT: targets expected to appear per scan in the "
                                       "sensor's coverage")] = 0.05
    clutter_density: Annotated[float | None, Field(gt=0, description="clutter per m^2; None: the local "
                                                   "estimate around each contact")] = None
    clutter_radius_m: Annotated[float, Field(gt=0, description="half-side (m) of the local estimate's "
                                             "square")] = 3_000.0
    clutter_estimate: Literal["local", "unexplained"] = Field(
        "unexplained", description="the local estimate (clutter_density None): 'local', every contact in the square "
        "(itself included); 'unexplained', the contacts there less the contact itself and the labels' expected "
        "detections (P_D P_G times existence) at their predicted positions, at least the scan's own such count "
        "over the coverage (`nnda.tracking.clutter_density.unexplained_density`)")
    gate: Annotated[float, Field(gt=0, description="chi-square gate, 2 dof (13.82: P_G = 0.999; a wide gate "
                                 "keeps a target whose track lags in a turn, where the existence, not the gate, "
                                 "weighs the contact against clutter)")] = 13.82
    admission_existence: Annotated[float, Field(ge=0, lt=1, description="existence at which a birth joins the "
                                                "hypotheses; below it the birth is a tentative label, updated "
                                                "alone on the contacts the best hypothesis leaves free; 0: every "
                                                "birth joins at once")] = 0.5
    min_tentative_existence: Annotated[float, Field(ge=0, lt=1, description="a tentative label of lower "
                                                    "existence is dropped")] = 1e-5
    report_existence: Annotated[float, Field(ge=0, lt=1, description="a confirmed label is reported while its "
                                             "existence is at least this; below it (two missed scans in a row "
                                             "at P_D 0.9) it is kept but not reported until a contact raises "
                                             "it again: 0.5 reports it where that lowers the expected GOSPA "
                                             "(a false track and a missed target cost alike); 0 reports every "
                                             "live label")] = 0.5

    @model_validator(mode="after")
    def _tentative_order(self) -> LabelledConfig:
        if self.lifecycle.report_existence is not None:
            raise ValueError(f"lifecycle.report_existence = {self.lifecycle.report_existence:g} is the contact "
                             f"trackers' output rule; a labelled tracker reports by its labels' own existence: "
                             f"set report_existence (now {self.report_existence:g}) instead")
        if 0 < self.admission_existence <= self.min_tentative_existence:
            raise ValueError(f"min_tentative_existence = {self.min_tentative_existence:g} must be below "
                             f"admission_existence = {self.admission_existence:g}: a tentative label would be "
                             f"dropped before it could join the hypotheses")
        return self


@dataclass(frozen=True)
class LabelledTable(Batch):
    """S labelled tracks: ``tracks`` their records (``tracks.track_id`` the label; the filter state at the
    last update, at ``tracks.t2``), existence ``r`` (S,), ``hist`` (S, n_scan) the contact of each of the last
    n_scan scans (oldest first; NO_CONTACT a miss), and the estimate reported for the last scan, ``x`` (S, 4)
    m, m/s and ``P`` (S, 4, 4)."""

    tracks: Tracks
    r: np.ndarray
    hist: np.ndarray
    x: np.ndarray
    P: np.ndarray

    def joined(self, other: LabelledTable) -> Self:
        """These rows, then ``other``'s (of the same class): `Batch.concat` of the two, the tracks and the four
        columns in one compiled call (`tracks.tables_joined`), a subclass's further fields after."""
        return self._of(tables_joined(self._arrays(), other._arrays()),
                        [np.concatenate((a, b)) for a, b in zip(self._fields()[5:], other._fields()[5:])])

    def _rows(self, index: np.ndarray | slice) -> Self:
        """`Batch.take` of an integer array: the tracks and the four columns in one compiled call
        (`tracks.table_rows`; the trackers take rows every scan, where a take field by field costs more than the
        copying), a subclass's further fields after."""
        if isinstance(index, slice):
            return super()._rows(index)
        return self._of(table_rows(self._arrays(), index), [a[index] for a in self._fields()[5:]])

    def _arrays(self) -> tuple[np.ndarray, ...]:
        """The tracks' arrays in `Tracks` order (the filter state's three in its place), then r, hist, x and P."""
        t = self.tracks
        f = t.filt
        return t.track_id, t.status, f.x, f.P, f.mu, t.history, t.counts, t.scores, self.r, self.hist, self.x, self.P

    def _of(self, arrays: tuple[np.ndarray, ...], rest: list[np.ndarray]) -> Self:
        """A table of this class from `_arrays`' tuple and the values of the fields a subclass adds, ``rest``."""
        track_id, status, x, P, mu, history, counts, scores, r, hist, ex, eP = arrays
        return type(self)(Tracks(track_id, status, IMMState(x, P, mu), history, counts, scores), r, hist, ex, eP,
                          *rest)


@dataclass(frozen=True)
class ScanUpdate:
    """One scan's children of S rows (`LabelledMixture._predict_update`): ``pd`` (S,) each row's detection
    probability (0 where the sensor cannot see it), the gated pairs (row ``pl``, contact ``pj``, IMM log
    likelihood ``ll`` and clutter density in measurement space ``clutter``, each (P,)), and the S + P
    children (the S miss children, row s, then one per pair): ``tracks``, ``hist`` (S + P, n_scan), ``x``
    (S + P, 4) and ``P`` (S + P, 4, 4) (the prediction after a miss)."""

    pd: np.ndarray
    pl: np.ndarray
    pj: np.ndarray
    ll: np.ndarray
    clutter: np.ndarray
    tracks: Tracks
    hist: np.ndarray
    x: np.ndarray
    P: np.ndarray


@dataclass(frozen=True)
class GatedRows:
    """S rows of a `LabelledTable` predicted to a scan and gated (`LabelledMixture._gated`): the ``rows``, their
    IMM prediction, rows ``first`` to ``first + S`` of ``pred`` (a batch the tracker predicted with other rows),
    each row's detection probability ``pd`` (S,) (0 where the sensor cannot see it) and the gated pairs (row
    ``pl`` of these S, contact ``pj``, IMM log likelihood ``ll``, clutter density in measurement space
    ``clutter``, each (P,))."""

    rows: LabelledTable
    pred: IMMPrediction
    first: int
    pd: np.ndarray
    pl: np.ndarray
    pj: np.ndarray
    ll: np.ndarray
    clutter: np.ndarray


class LabelledMixture(ContactTracker):
    """A contact tracker whose density is a mixture of global hypotheses over labelled tracks (module
    docstring). ``cap_field`` names the config field capping the hypotheses, ``hypotheses`` what the bound
    warning calls them."""

    cap_field: ClassVar[str]
    hypotheses: ClassVar[str]
    own_confirmation: ClassVar[str | None] = "existence"  # status from existence alone (module docstrings)
    learns_pd = True

    def reset(self) -> None:
        super().reset()
        self.table: LabelledTable | None = None  # the tracks the hypotheses index
        self.labels = np.empty(0, np.int64)  # (L,) live labels
        self.hyp = np.zeros((1, 0), np.int64)  # (H, L) row of each label per hypothesis, -1 absent
        self.log_w = np.zeros(1)  # (H,) normalised log weights
        self.known = (np.empty(0, np.int64), np.empty((0, 4)), np.empty((0, 4, 4)))  # reported labels, last x, P
        self.confirmed = np.empty(0, np.int64)  # labels reported confirmed
        self.n_capped = 0  # scans where the hypothesis cap bit
        self.tentative: LabelledTable | None = None  # births below admission_existence, each updated alone
        self.cardinality: Cardinality | None = None  # the target count after the last scan (`_count`)
        self._unseen: np.ndarray | None = None  # labels the last scan did not observe (`_gated`); None: none

    # ---------------------------------------------------------------------- one scan
    def _predict_update(self, scan: ScanContacts, g: GatedRows) -> ScanUpdate:
        """The children of the gated rows ``g`` (the mixture's, `_gated`): the detection children updated in one
        batch (`nnda.tracking.linearisation.update`), the miss children keeping their posterior (`_child_rows`)."""
        tracks, hist, x, P = self._child_rows(scan, g)
        return ScanUpdate(g.pd, g.pl, g.pj, g.ll, g.clutter, tracks, hist, x, P)

    def _gated(self, scan: ScanContacts) -> tuple[GatedRows | None, GatedRows | None]:
        """The mixture's rows (``table``) and the tentative labels (``tentative``) predicted to the scan and
        gated, all in one batch (one prediction, one gate); None for a table the tracker has not now. The
        mixture's rows set the scan's expected detections (`unexplained_density`) before any clutter density is
        asked."""
        cfg, imm, z, xy = self.config, scan.filter, scan.z, scan.xy
        tables = [t for t in (self.table, self.tentative) if t is not None]
        if not tables:
            return None, None
        S = 0 if self.table is None else len(self.table)
        if len(tables) == 1:
            filt, t2 = tables[0].tracks.filt, tables[0].tracks.t2
        else:
            x, P, mu, t2 = _stacked(self.table._arrays(), self.tentative._arrays())
            filt = IMMState(x, P, mu)
        pred = imm.predict(filt, scan.time - t2, check=False)
        pd = np.full(len(filt), self.score_pd(scan.sensor))
        observed = self._observed(scan, pred)
        self._unseen = None
        if observed is not None:
            pd = np.where(observed, pd, 0.0)
            if S and self._learns(scan):  # only `_count_best` reads it
                self._unseen = self.table.tracks.track_id[:S][~observed[:S]]
        if S and self._unexplained:
            self._explained = (scan, pred.gating.x[:S, 0:3:2], self._expected_detections(self.table.r * pd[:S]))
        pl = pj = np.empty(0, np.int64)
        ll = clutter = np.empty(0)
        if len(z):
            g = pred.gating
            gated = gate(imm, g.measurement, z, xy, cfg.gate, (g.x, g.P), check=False)
            ok = pd[gated.rows] > 0
            pl, pj = gated.rows[ok], gated.cols[ok]
            if pl.size:
                ll = imm.pair_log_likelihood(pred, pl, z[pj], check=False)
                clutter = self._clutter(scan, pj)
        cut = int(np.searchsorted(pl, S))  # the gate's pairs come by row: the mixture's, then the tentative labels'
        return (None if self.table is None else
                GatedRows(self.table, pred, 0, pd[:S], pl[:cut], pj[:cut], ll[:cut], clutter[:cut]),
                None if self.tentative is None else
                GatedRows(self.tentative, pred, S, pd[S:], pl[cut:] - S, pj[cut:], ll[cut:], clutter[cut:]))

    def _count_best(self, scan: ScanContacts) -> None:
        """After the scan's update: the detections of the best hypothesis's labels reported confirmed before
        it, for the P_D record (`ContactTracker._count_detections`): each label's row took a contact or missed;
        a label the scan did not observe is left out."""
        if not (self._learns(scan) and self.labels.size) or self.table is None:
            return
        chosen = self.hyp[int(np.argmax(self.log_w))]
        shown = np.flatnonzero(chosen >= 0)
        label = self.labels[shown]
        seen = None if self._unseen is None else ~members(label, self._unseen)
        self._count_detections(scan, members(label, self.confirmed), seen, self.table.hist[chosen[shown], -1])

    def _child_rows(self, scan: ScanContacts, g: GatedRows, chosen: np.ndarray | None = None
                  ) -> tuple[Tracks, np.ndarray, np.ndarray, np.ndarray]:
        """The children of the gated rows ``g``: the S miss children (row s), then one per gated pair, or only
        those ``chosen`` (indices into that list, in their order): track records, histories (n_scan columns),
        estimates x (., 4) and P (., 4, 4), in one compiled call (`_children`). Each child is computed alone
        (the update and the records row by row), so a chosen few are the same as when every child is made. A
        pair whose track the polar model linearises poorly takes the converted-measurement update afterwards,
        as `nnda.tracking.linearisation.update` gives it."""
        imm, old, pred, first = scan.filter, g.rows, g.pred, g.first
        tr, st, mp = old.tracks, pred.state, pred.measurement
        every = np.arange(len(old) + g.pl.size) if chosen is None else chosen
        track_id, status, fx, fP, fmu, history, counts, scores, hist, x, P, parent, poor = _children(
            every, first, g.pl, g.pj, (tr.track_id, tr.status, tr.counts, tr.scores, tr.history, old.hist),
            (tr.filt.x, tr.filt.P, tr.filt.mu), (pred.gating.x, pred.gating.P),
            (st.x, st.P, st.mu, mp.z, mp.S_inv, mp.log_det_S, mp.PHt, mp.S), scan.z, scan.xy, scan.time,
            imm.polar, LINEARISATION_LIMIT_RAD ** 2, imm.output_dim, *branching_args(self.config.lifecycle))
        if poor.size:  # near the radar: rare
            xy, R = imm.measurement.position(scan.z[hist[poor, -1]])
            fixed = imm.update_position(pred.take(first + parent[poor]), xy, R)
            fx[poor], fP[poor], fmu[poor] = fixed.x, fixed.P, fixed.mu
            x[poor], P[poor] = imm.estimate(fixed)
        return Tracks(track_id, status, IMMState(fx, fP, fmu), history, counts, scores), hist, x, P

    def _expected_detections(self, r_pd: np.ndarray) -> np.ndarray:
        """Each row's expected detections in this scan (S,): P_G p_S times ``r_pd`` (S,), its existence times
        its P_D, times the weight of the hypotheses holding it."""
        held = self.hyp >= 0
        weight = np.bincount(self.hyp[held], np.broadcast_to(np.exp(self.log_w)[:, None], self.hyp.shape)[held],
                             minlength=r_pd.size)
        return gate_probability(self.config.gate) * self.config.survival_probability * r_pd * weight

    def _clutter(self, scan: ScanContacts, at: np.ndarray) -> np.ndarray:
        """Clutter density in the scan's measurement space at its contacts ``at`` (M,): the fixed
        ``clutter_density`` or the local estimate (`ContactTracker.clutter_density`), times the area
        Jacobian."""
        if self.config.clutter_density is None:
            return self.clutter_density(scan, at)
        return self.config.clutter_density * scan.filter.measurement.area_jacobian(scan.z[at])

    # ---------------------------------------------------------------------- births
    def _births(self, scan: ScanContacts, used: np.ndarray, taken: np.ndarray | None = None, live: int = 0
                ) -> tuple[Tracks | None, np.ndarray | None]:
        """Two-point starts (`TwoPointInitiation`) with the contacts no label took in the best hypothesis
        (``used`` (N,), `_used`; marked further here) nor ``taken`` (indices into the scan's contacts), given
        ``live`` labels besides the mixture's."""
        if taken is not None:
            used[taken[taken >= 0]] = True
        return self.initiation(scan.z, scan.xy, used, scan.time, self.labels.size + live, scan.sensor)

    def _used(self, scan: ScanContacts) -> np.ndarray:
        """(N,) bool: the scan's contacts a label took in the best hypothesis."""
        used = np.zeros(len(scan.z), bool)
        if self.table is not None:
            best = self.hyp[int(np.argmax(self.log_w))]
            now = self.table.hist[best[best >= 0], -1]
            used[now[now >= 0]] = True
        return used

    def _birth_existence(self, born: Tracks, contact: np.ndarray, scan: ScanContacts
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Existence (B,) of each new pair and its log odds (B,), new target against clutter (module
        docstring)."""
        cfg, sensor, area = self.config, self.sensors[scan.sensor], self._window_areas[scan.sensor]
        if cfg.clutter_density is None:
            rho2 = self._contact_density(scan)[contact]
            if self._unexplained:  # the pair's second contact, in the square around its first, left out too
                own = (np.abs(scan.xy[contact] - born.p1) < cfg.clutter_radius_m).all(axis=1)
                rho1 = self._unexplained_density(scan, born.p1, own.astype(float))
            else:
                rho1 = local_density(scan.xy, born.p1, cfg.clutter_radius_m, sensor)
        else:
            rho2 = rho1 = np.full(len(born), cfg.clutter_density)
        pd = self.score_pd(scan.sensor)
        log_odds = start_score(pd, area, rho2) + birth_log_odds(pd, cfg.birth_rate / coverage_area(sensor), rho1)
        return np.exp(-np.logaddexp(0.0, -log_odds)), log_odds

    def _tentative_children(self, scan: ScanContacts, g: GatedRows, used: np.ndarray
                            ) -> tuple[LabelledTable | None, np.ndarray, np.ndarray]:
        """The T tentative labels, gated in ``g`` (`_gated`), each updated alone, in one batch, on the contacts
        the best hypothesis left free (not ``used`` (N,), `_used`; `nnda.tracking.glmb`, tentative labels):
        each label's heaviest child (its miss or a gated contact) with the label's new existence. Returns the
        children of existence ``min_tentative_existence`` or more (only those are made, `_child_rows`; None:
        none), which of them reached ``admission_existence``, and the contact every label's child took (T,)
        (NO_CONTACT: its miss)."""
        cfg, tent = self.config, g.rows
        T = len(tent)
        ok = ~used[g.pj]
        pl = g.pl[ok]
        with np.errstate(divide="ignore"):  # P_D 1: a miss weighs 0
            log_w = np.concatenate([np.log1p(-g.pd), np.log(g.pd[pl]) + g.ll[ok] - np.log(g.clutter[ok])])
        total, chosen, contact = _heaviest(pl, log_w, np.flatnonzero(ok), g.pj[ok], T)
        alive = cfg.survival_probability * tent.r
        r = np.exp(-np.logaddexp(0.0, -(np.log(alive) - np.log1p(-alive) + total)))
        ready = r >= cfg.admission_existence
        keep = np.flatnonzero(ready | (r >= cfg.min_tentative_existence))
        if not keep.size:
            return None, ready[keep], contact
        tracks, hist, x, P = self._child_rows(scan, g, chosen[keep])
        return LabelledTable(tracks, r[keep], hist, x, P), ready[keep], contact

    def _sorted_tentative(self, kids: LabelledTable | None, ready: np.ndarray
                          ) -> tuple[LabelledTable | None, LabelledTable | None]:
        """Updated tentative labels ``kids`` (`_tentative_children`) split: those that reached
        ``admission_existence``, ``ready`` (to join the hypotheses), and the rest (tentative still), each None
        when empty."""
        if kids is None or not ready.any():
            return None, kids
        return kids.take(np.flatnonzero(ready)), None if ready.all() else kids.take(np.flatnonzero(~ready))

    # ---------------------------------------------------------------------- pruning
    def _prune(self, hyp: np.ndarray, log_w: np.ndarray) -> None:
        """The mixture ``hyp`` (H, L), ``log_w`` (H,) without the hypotheses lighter than
        ``min_hypothesis_weight`` or N-scan pruned (`n_scan_agrees`), at most the cap's heaviest (a
        `BoundWarning` the first time in a run, ``n_capped`` counts the scans), renormalised, without the labels
        and rows no hypothesis holds (`_pruned`)."""
        cfg = self.config
        cap = getattr(cfg, self.cap_field)
        least = math.log(cfg.min_hypothesis_weight) if cfg.min_hypothesis_weight > 0 else -math.inf
        over, self.hyp, self.log_w, live, used = _pruned(hyp, log_w, np.ascontiguousarray(self.table.hist[:, 0]),
                                                         least, cap)
        if over:
            self._bound_hit(self.cap_field, f"{over} {self.hypotheses} pruned past the cap", self.last_time)
            self.n_capped += 1
        self.labels = self.labels[live]
        self.table = self.table.take(used) if used.size else None

    # ---------------------------------------------------------------------- output
    def existence(self) -> np.ndarray:
        """Existence probability (L,) of each live label (``labels``): the weights of the hypotheses holding it,
        times its row's existence there (`_existence`)."""
        if self.table is None:
            return np.zeros(self.labels.size)
        return _existence(self.hyp, np.exp(self.log_w), self.table.r)[1]

    def _count(self, scan: int, time: float, extracted: int, moments: tuple[float, float, float, float]
               ) -> Cardinality:
        """The target count after scan ``scan``: mean and variance of the number of live labels, a mixture over
        the hypotheses (weights w_h) of multi-Bernoulli counts (mean sum r, variance sum r (1 - r) in each),
        the tentative labels' Bernoullis added to every hypothesis, from the ``moments`` of `_moments`."""
        first, second, tentative_mean, tentative_variance = moments
        mean = float(first)
        variance = float(second) - mean ** 2
        if self.tentative is not None:
            mean += float(tentative_mean)
            variance += float(tentative_variance)
        return Cardinality(scan, time, mean, None, None, extracted, max(variance, 0.0))

    def _waiting(self) -> list[LabelledTable]:
        """Rows reported PRELIMINARY after the best hypothesis's, live though in no hypothesis yet: the tentative
        labels (a list of tables, in order; empty: none)."""
        return [] if self.tentative is None else [self.tentative]

    def _report(self, scan: int, time: float) -> TrackerOutput:
        """The best hypothesis's labels with their row's estimate and contact, CONFIRMED once their existence
        has reached ``existence_threshold`` (and left out while a confirmed label's existence is below
        ``report_existence``), PRELIMINARY before; then the waiting rows (`_waiting`); then the reported labels
        deleted in this scan, DELETED with their last estimate (one compiled pass, `_reported`)."""
        cfg, table = self.config, self.table
        ids, x, P = self.known
        s, label, r, moments = _best_shown(self.hyp, self.log_w, np.exp(self.log_w),
                                           np.empty(0) if table is None else table.r, self.labels,
                                           np.empty(0) if self.tentative is None else self.tentative.r)
        waiting = self._waiting()
        if len(waiting) == 1:  # only the fields reported, not whole tables joined
            new, wx, wP, contact = waiting[0].tracks.track_id, waiting[0].x, waiting[0].P, waiting[0].hist[:, -1]
        elif waiting:
            new, wx, wP, contact = (np.concatenate(a) for a in zip(*((t.tracks.track_id, t.x, t.P, t.hist[:, -1])
                                                                      for t in waiting)))
        else:
            new, wx, wP, contact = np.empty(0, np.int64), np.empty((0, 4)), np.empty((0, 4, 4)), np.empty(0, np.int64)
        if table is not None:
            tx, tP, tc = table.x, table.P, np.ascontiguousarray(table.hist[:, -1])
        else:
            tx, tP, tc = np.empty((0, 4)), np.empty((0, 4, 4)), np.empty(0, np.int64)
        self.confirmed, lost, track_id, status, x, P, contact, *known = _reported(
            ids, x, P, label, r, s, tx, tP, tc, new, wx, wP, np.ascontiguousarray(contact), self.labels,
            self.confirmed, cfg.existence_threshold, cfg.report_existence)
        self.deletions["score"] += int(lost.sum())
        self.deletions["unconfirmed"] += int(lost.size - lost.sum())
        self.known = tuple(known)
        out = TrackerOutput(scan, time, track_id, status, x, P, contact)
        self.cardinality = self._count(scan, time, int((out.status == CONFIRMED).sum()), moments)
        return out


@numba.njit(cache=True, nogil=True)
def _children(every, first, pl, pj, records, filt, gating, predicted, z, xy, time, polar, limit, d, m,
              misses_to_delete, max_misses, score_rule, exist, own_confirm, own_delete, lower, upper, early, run):
    """`LabelledMixture._child_rows` in one pass: the children ``every`` (M,) (`_family`) of S gated rows, rows
    ``first`` to ``first + S`` of a prediction, with the gated pairs (row ``pl``, contact ``pj``, (P,) each). The
    rows' ``records`` (track_id, status, counts, scores, history of `Tracks`, and ``hist`` (S, n_scan)) and filter
    states ``filt`` (x, P, mu); the prediction's combined estimate ``gating`` (x (K, d), P (K, d, d)) and
    ``predicted``, its model states (x, P, mu) and measurement prediction (z, S_inv, log_det_S, PHt, S) with (K, r)
    leading; the scan's contacts z (N, 2), their positions xy (N, 2) m and its ``time`` s; whether the sensor is
    ``polar``, the linearisation's ``limit`` on S_aa (rad^2), the output dimension ``d`` and the life cycle's
    `branching_args`. A pair child is its row's prediction updated with its contact (`imm_kernels.update`, then
    `imm_kernels.estimate`), a miss child keeps its row's posterior and reports the prediction; the records move
    on as `Tracks.after_scan` moves a scan's tracks (`tracks.branched_moved`). Returns the children's track_id,
    status, x, P, mu, history, counts, scores, hist, estimate x (M, d) and P (M, d, d), parent (M,) (of the S
    rows) and the pair children whose track the polar model linearises poorly
    (`nnda.tracking.linearisation.poor_rows`; indices into the M), for the caller's converted-measurement update."""
    track_id, status, counts, scores, history, hist = records
    fx, fP, fmu = filt
    gx, gP = gating
    xp, Pp, mu_p, z_pred, S_inv, log_det, PHt, S_meas = predicted
    pair, parent, contact, at_miss, at_pair = _family(every, track_id.size, pl, pj)
    rows = first + pl[pair]
    detected = np.ones(pair.size, np.bool_)
    ux, uP, umu = imm_kernels.update(xp[rows], Pp[rows], mu_p[rows], z[pj[pair]], detected, z_pred[rows],
                                     S_inv[rows], log_det[rows], PHt[rows], polar)
    ex, eP = imm_kernels.estimate(ux, uP, umu, d)
    M = every.size
    x, P, mu = np.empty((M,) + fx.shape[1:]), np.empty((M,) + fP.shape[1:]), np.empty((M,) + fmu.shape[1:])
    cx, cP = np.empty((M, d)), np.empty((M, d, d))
    for i in range(at_miss.size):
        k, s = at_miss[i], parent[at_miss[i]]
        x[k], P[k], mu[k], cx[k], cP[k] = fx[s], fP[s], fmu[s], gx[first + s], gP[first + s]
    for q in range(pair.size):
        k = at_pair[q]
        x[k], P[k], mu[k], cx[k], cP[k] = ux[q], uP[q], umu[q], ex[q], eP[q]
    poor = at_pair[poor_rows(S_meas[rows], detected, limit)] if polar else np.empty(0, np.int64)
    status, counts, scores, history, _, _ = branched_moved(
        parent, contact, np.ones(M, np.bool_), status, counts, scores, history, m, misses_to_delete, max_misses,
        score_rule, exist, own_confirm, own_delete, lower, upper, early, run, xy, z[:, 1].copy(), time)
    n_scan = hist.shape[1]
    new_hist = np.empty((M, n_scan), np.int64)
    for k in range(M):
        new_hist[k, :n_scan - 1] = hist[parent[k], 1:]
        new_hist[k, n_scan - 1] = contact[k]
    return track_id[parent], status, x, P, mu, history, counts, scores, new_hist, cx, cP, parent, poor


@numba.njit(cache=True, nogil=True)
def _stacked(a, b):
    """The filter states of two tables' tracks (their `LabelledTable._arrays`) ``a`` then ``b``, stacked: x, P, mu,
    and the time (s) of each track's last update, t2."""
    return (np.concatenate((a[2], b[2])), np.concatenate((a[3], b[3])), np.concatenate((a[4], b[4])),
            np.concatenate((a[5][:, T2], b[5][:, T2])))


@numba.njit(cache=True, nogil=True)
def _family(every, S, pl, pj):
    """The children ``every`` (M,) of S gated rows (`LabelledMixture._child_rows`: s < S the miss child of row s,
    S + p that of gated pair p, of row ``pl[p]`` and contact ``pj[p]``): the pairs among them (indices into the
    pairs), each child's parent row (M,) and contact (M,) (NO_CONTACT for a miss), and the places (into
    ``every``) of its misses and of its pairs."""
    n_pair = 0
    for c in every:
        n_pair += c >= S
    pair, at_pair = np.empty(n_pair, np.int64), np.empty(n_pair, np.int64)
    at_miss = np.empty(every.size - n_pair, np.int64)
    parent, contact = every.copy(), np.full(every.size, NO_CONTACT, np.int64)
    p = m = 0
    for k in range(every.size):
        if every[k] >= S:
            pair[p], at_pair[p] = every[k] - S, k
            parent[k], contact[k] = pl[every[k] - S], pj[every[k] - S]
            p += 1
        else:
            at_miss[m] = k
            m += 1
    return pair, parent, contact, at_miss, at_pair


@numba.njit(cache=True, nogil=True)
def _heaviest(owner, log_w, pair, contact, T):
    """Each of T tentative labels' children weighed (`LabelledMixture._tentative_children`): ``log_w`` (T + Q,)
    the labels' misses, then Q gated pairs of labels ``owner`` (Q,), which are the gated pairs ``pair`` (Q,), of
    contacts ``contact`` (Q,). Returns each label's summed weight (T,), ln of the sum of its children's
    weights, added in their order as numpy's ``logaddexp.at`` would; its heaviest child (T,): the label's miss
    (its index) or T + the gated pair's index, the first of equal weights; and that child's contact (T,)
    (NO_CONTACT: the miss). One compiled pass."""
    total = np.full(T, -np.inf)
    chosen = np.arange(T)
    taken = np.full(T, NO_CONTACT, np.int64)
    top = np.empty(T)
    for t in range(T):
        total[t], top[t] = logaddexp(total[t], log_w[t]), log_w[t]
    for q in range(owner.size):
        t, w = owner[q], log_w[T + q]
        total[t] = logaddexp(total[t], w)
        if w > top[t]:
            top[t], chosen[t], taken[t] = w, T + pair[q], contact[q]
    return total, chosen, taken


@numba.njit(cache=True, nogil=True)
def _existence(hyp, w, r):
    """The existence of each label's row in each hypothesis, (H, L) (0 where the label is absent), of the
    mixture ``hyp`` (H, L) of weights ``w`` (H,) over rows of existence ``r`` (S,), and each label's marginal
    existence (L,): sum over h of w_h times its row's, added hypothesis by hypothesis as numpy sums a (H, L)
    array over its first axis (in turn; for one label, a contiguous column: its pairwise sum,
    `exact.add_reduce`). Not a matrix product: BLAS rounds it by the arrays' alignment in memory."""
    H, L = hyp.shape
    rows = np.zeros((H, L))
    for h in range(H):
        for j in range(L):
            if hyp[h, j] >= 0:
                rows[h, j] = r[hyp[h, j]]
    marginal = np.zeros(L)
    if L == 1:
        marginal[0] = add_reduce(w * rows[:, 0])
    else:
        for h in range(H):
            for j in range(L):
                marginal[j] += w[h] * rows[h, j]
    return rows, marginal


@numba.njit(cache=True, nogil=True)
def _best_shown(hyp, log_w, w, r, labels, rt):
    """What `LabelledMixture._report` shows of the mixture ``hyp`` (H, L) of log weights ``log_w`` (H,) (weights
    ``w``) over rows of existence ``r`` (S,), of live ``labels`` (L,), with tentative labels of existence ``rt``
    (T,): the rows of the heaviest hypothesis's labels (the first of equal weights), those labels, their marginal
    existence (`_existence`), and the count's `_moments`."""
    rows, marginal = _existence(hyp, w, r)
    best = hyp[np.argmax(log_w)]
    shown = np.flatnonzero(best >= 0)
    return best[shown], labels[shown], marginal[shown], _moments(w, rows, rt)


@numba.njit(cache=True, nogil=True)
def _moments(w, r, rt):
    """`LabelledMixture._count`'s sums: over the hypotheses of weights ``w`` (H,) with their rows' existence
    ``r`` (H, L), sum w_h mu_h and sum w_h (v_h + mu_h^2) (mu_h = sum r, v_h = sum r (1 - r) in hypothesis h),
    and the tentative labels' sum rt and sum rt (1 - rt) (``rt`` (T,)); each sum as numpy's (`exact.add_reduce`;
    not a matrix product, which BLAS rounds by the arrays' alignment in memory)."""
    H, L = r.shape
    first, second = np.empty(H), np.empty(H)
    spread = np.empty(L)
    for h in range(H):
        for j in range(L):
            spread[j] = r[h, j] * (1.0 - r[h, j])
        mu = add_reduce(r[h])
        first[h], second[h] = w[h] * mu, w[h] * (add_reduce(spread) + mu * mu)
    spread_t = np.empty(rt.size)
    for t in range(rt.size):
        spread_t[t] = rt[t] * (1.0 - rt[t])
    return add_reduce(first), add_reduce(second), add_reduce(rt), add_reduce(spread_t)


@numba.njit(cache=True, nogil=True)
def _reported(ids, kx, kP, label, r, s, tx, tP, tc, new, wx, wP, wc, labels, confirmed, threshold, report):
    """`LabelledMixture._report`'s output and books in one pass: the labels reported before, ``ids`` (K,) with
    their last estimates kx (K, d), kP (K, d, d); the best hypothesis's labels ``label`` (n,) of existence ``r``
    (n,) at rows ``s`` (n,) of the table's estimates tx, tP and contacts ``tc``; the waiting rows' labels
    ``new`` (W,), estimates wx, wP and contacts ``wc``; the live ``labels``, the ``confirmed`` so far and the
    two thresholds (`_bookkeeping`). Returns the confirmed labels after the scan, whether each deleted label
    was confirmed (D,), the output's fields (track_id, status, x, P, contact: the reported labels of the best
    hypothesis, the waiting rows, the deleted labels), and the labels known after the scan with their
    estimates."""
    confirmed, was, seen, old, mine, known, gone, lost = _bookkeeping(ids, label, r, new, labels, confirmed,
                                                                      threshold, report)
    n_seen = 0
    for i in range(seen.size):
        n_seen += seen[i]
    K = n_seen + new.size + lost.size
    out_id, out_status = np.empty(K, np.int64), np.empty(K, np.int8)
    out_x, out_P = np.empty((K,) + tx.shape[1:]), np.empty((K,) + tP.shape[1:])
    out_c = np.full(K, NO_CONTACT, np.int64)
    k = 0
    for i in range(label.size):
        if seen[i]:
            out_id[k], out_status[k], out_c[k] = label[i], CONFIRMED if was[i] else PRELIMINARY, tc[s[i]]
            out_x[k], out_P[k] = tx[s[i]], tP[s[i]]
            k += 1
    for i in range(new.size):
        out_id[k], out_status[k], out_c[k] = new[i], PRELIMINARY, wc[i]
        out_x[k], out_P[k] = wx[i], wP[i]
        k += 1
    n_known = known.size - lost.size
    known_x, known_P = np.empty((n_known,) + tx.shape[1:]), np.empty((n_known,) + tP.shape[1:])
    known_id = np.empty(n_known, np.int64)
    q = 0
    for i in range(known.size):  # the estimate each known label has now: as before, its row's, or waiting's
        if i < old.size:
            x, P = kx[old[i]], kP[old[i]]
        elif i < old.size + mine.size:
            x, P = tx[s[mine[i - old.size]]], tP[s[mine[i - old.size]]]
        else:
            x, P = wx[i - old.size - mine.size], wP[i - old.size - mine.size]
        if gone[i]:
            out_id[k], out_status[k] = known[i], DELETED
            out_x[k], out_P[k] = x, P
            k += 1
        else:
            known_id[q] = known[i]
            known_x[q], known_P[q] = x, P
            q += 1
    return confirmed, lost, out_id, out_status, out_x, out_P, out_c, known_id, known_x, known_P


@numba.njit(cache=True, nogil=True)
def _bookkeeping(ids, label, r, new, labels, confirmed, threshold, report):
    """The labels' bookkeeping of `LabelledMixture._report`: ``ids`` (K,) the labels reported before, ``label``
    (n,) the best hypothesis's labels of existence ``r`` (n,), ``new`` (W,) the waiting rows' labels,
    ``labels`` (L,) the live labels, ``confirmed`` (C,) ascending, those reported confirmed so far, and the
    ``existence_threshold`` and ``report_existence``. Returns the confirmed labels after the scan (ascending;
    the deleted ones gone), which of ``label`` are confirmed (n,) and reported (n,), the labels known after the
    scan, ``known``: the old ones kept, ``old`` (indices into ``ids``: those in neither ``label`` nor ``new``),
    then ``label[mine]``, then ``new``; which of those are deleted (not live), ``gone``, and whether each deleted
    one was confirmed, ``lost`` (D,). One compiled pass."""
    confirmed = np.unique(np.concatenate((confirmed, label[r >= threshold])))
    was = among(label, confirmed)
    seen = ~was | (r >= report)
    old = np.flatnonzero(~among(ids, np.concatenate((label, new))))
    mine = np.flatnonzero(~among(label, new))
    known = np.concatenate((ids[old], label[mine], new))
    gone = ~among(known, np.concatenate((labels, new)))
    lost = among(known[gone], confirmed)
    return confirmed[~among(confirmed, known[gone])], was, seen, old, mine, known, gone, lost


def normalised(log_w: np.ndarray) -> np.ndarray:
    """Log weights (H,) shifted so that their exponentials sum to one."""
    return log_w - np.logaddexp.reduce(log_w)


def merged(hyp: np.ndarray, log_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Equal global hypotheses (rows of ``hyp`` (H, L)) as one, their log weights (H,) summed: the distinct
    rows in lexicographic order and their log weights."""
    if not hyp.shape[1]:
        return hyp[:1], np.logaddexp.reduce(log_w, keepdims=True)
    return _merged(np.ascontiguousarray(hyp, np.int64), np.asarray(log_w, np.float64))


@numba.njit(cache=True, nogil=True)
def _merged(hyp, log_w):
    """`merged` of ``hyp`` (H, L), L > 0, and ``log_w`` (H,): the rows sorted (`nnda.tracking.gibbs.row_order`,
    stable), each run of equal rows (`nnda.tracking.gibbs.run_heads`) with its weights summed in its rows' order,
    as numpy's ``logaddexp.reduceat`` would. One compiled pass."""
    H = hyp.shape[0]
    order = row_order(hyp)
    head = run_heads(hyp, order)
    first = np.empty(H, np.int64)  # the first row of each run of equal rows
    w = np.empty(H)
    k = -1
    for q in range(H):
        r = order[q]
        if head[q]:
            k += 1
            first[k], w[k] = r, log_w[r]
        else:
            w[k] = logaddexp(w[k], log_w[r])
    return hyp[first[:k + 1]], w[:k + 1]


@numba.njit(cache=True, nogil=True)
def _pruned(hyp, log_w, oldest, least, cap):
    """`LabelledMixture._prune` of the mixture ``hyp`` (H, L), ``log_w`` (H,) over S rows, ``oldest`` (S,) each
    row's contact ``n_scan`` back: the hypotheses of log weight ``least`` or more (-inf: all) that agree with
    the heaviest on that scan (`n_scan_agrees`; the heaviest always kept), at most the ``cap`` heaviest (ties:
    the first), in their order, their log weights normalised (summed as numpy's ``logaddexp.reduce`` would);
    then the labels some kept hypothesis holds and the rows they hold, renumbered in order. Returns how many
    the cap pruned, the kept hypotheses (H', L'), their log weights (H',), which labels stay (L,) and which
    rows (ascending). One compiled pass."""
    H, L = hyp.shape
    best = np.argmax(log_w)
    held = np.empty((H, L), np.int64)
    for h in range(H):
        for j in range(L):
            held[h, j] = oldest[max(hyp[h, j], 0)]
    keep = n_scan_agrees(hyp, held, best)
    for h in range(H):
        keep[h] &= least == -np.inf or log_w[h] >= least
    keep[best] = True
    idx = np.flatnonzero(keep)
    over = max(idx.size - cap, 0)
    if over:
        idx = np.sort(idx[np.argsort(-log_w[idx], kind="mergesort")[:cap]])
    w = log_w[idx]
    total = w[0]
    for i in range(1, w.size):
        total = logaddexp(total, w[i])
    live = np.zeros(L, np.bool_)
    rows = np.zeros(oldest.size, np.bool_)
    for h in idx:
        for j in range(L):
            if hyp[h, j] >= 0:
                live[j] = True
                rows[hyp[h, j]] = True
    used = np.flatnonzero(rows)
    remap = np.full(oldest.size, -1, np.int64)
    remap[used] = np.arange(used.size)
    cols = np.flatnonzero(live)
    out = np.full((idx.size, cols.size), -1, np.int64)
    for a in range(idx.size):
        for b in range(cols.size):
            if hyp[idx[a], cols[b]] >= 0:
                out[a, b] = remap[hyp[idx[a], cols[b]]]
    return over, out, w - total, live, used


@numba.njit(cache=True, nogil=True)
def n_scan_agrees(hyp: np.ndarray, oldest: np.ndarray, best: int) -> np.ndarray:
    """N-scan pruning (H,): which hypotheses ``hyp`` (H, L) agree with hypothesis ``best`` on the scan ``n_scan``
    back, ``oldest`` (H, L) each row's contact there. A label present in both must have made the same choice
    (contact or miss), and no contact that a label of ``best`` took may be taken by another one. A label absent
    from one of them (dead there, or pruned for its low existence) constrains nothing by itself: its absence
    says nothing of that scan, so the hypotheses where a target has ended since stay beside those where it
    coasts, and its existence falls with each miss. One compiled pass."""
    H, L = hyp.shape
    top = -1
    for h in range(H):
        for j in range(L):
            if hyp[h, j] >= 0:
                top = max(top, oldest[h, j])
    owned = np.zeros(top + 1, np.bool_)  # the contacts a label of the best hypothesis took there
    for j in range(L):
        if hyp[best, j] >= 0 and oldest[best, j] >= 0:
            owned[oldest[best, j]] = True
    agrees = np.ones(H, np.bool_)
    for h in range(H):
        for j in range(L):
            if hyp[h, j] < 0:
                continue
            c = oldest[h, j]
            # present in both: the same choice; absent from the best: none of the best's contacts
            if (c != oldest[best, j]) if hyp[best, j] >= 0 else (c >= 0 and owned[c]):
                agrees[h] = False
                break
    return agrees
