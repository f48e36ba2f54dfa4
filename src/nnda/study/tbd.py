"""The track-before-detect study (Bruno, Araújo & Pavlov): every filter on the same Monte Carlo frames.

At each PTCR, ``runs`` runs of ``frames`` frames (`nnda.data.frames`, run r
drawn from (seed, r) at every PTCR, so the truths and the clutter are
shared and only the amplitude differs) are filtered by every filter
(`nnda.filters.tbd.run_tbd`), in blocks of ``chunk_runs`` runs. The study
engine runs it as the ``tbd`` job kind (`nnda.study.kinds.tbd`), its jobs
and the assembly of their records in `nnda.study.tbd_runs`; this module holds
the study's configuration and its measures.

The filters run on their own acceleration-noise intensity `FILTER_Q`
(``tbd.q``), not the frames' q = 6 pixels^2 per time unit^3: under that q a
particle's velocity hardly moves from frame to frame, so a filter without a
move step keeps whatever velocity its cloud collapsed onto and drifts off
the target, or loses it.

Divergence rule: a frame is lost when the truth is present and the filter
declares it absent or puts its conditional-mean position more than
``divergence_px`` pixels from the truth, or the truth is absent and the
filter declares it present; a run diverged when its last
``divergence_frames`` frames are all lost. Per filter and PTCR: the
divergent runs with their Clopper-Pearson interval, the per-frame RMSE of
x, y and position over the truth-present frames of the runs that did not
diverge and of all runs, the steady-state (last ``steady_frames`` frames)
per-run position error with a t-interval (both over the frames with a
position estimate: every frame of a filter, the frames with a confirmed
track of the chain below), the share of truth-present
frames declared present after ``acquisition`` frames, the likelihood
evaluations per frame (the cost axis) and the time. Comparisons: each
pair of filters at a PTCR and each filter across the PTCRs by Fisher's
exact test on the divergence counts, and each filter's count against the
paper's.

The conventional chain runs beside the filters on the same frames: the
per-frame matched-filter detector
(`nnda.filters.frame_likelihood.detections`) at ``detector_pfa`` per
position and aspect, scored by its probability of a detection within
``divergence_px`` of a present target, its other (false) detections per
frame and its cost (template correlations and milliseconds per frame);
then, with ``chain`` set, its detections tracked by nnda's GNN and MHT
(`nnda.study.tbd_chain`: a confirmed track is a "present" decision, the
best confirmed track's position the estimate), scored by the same
measures as the filters, with each chain tracker's divergence compared to
each filter's (Fisher) and its per-run share of truth-present frames
declared present after ``acquisition`` less the filter's (paired over the
same runs, with a t-interval).

With ``exit_reentry`` set, the study also runs the paper's 50-frame
demonstration (``scenario`` "exit-reentry" of `nnda.data.frames`: the
target leaves the frame, frames without a target follow, a new one
enters): per filter, the share of truth-present frames declared present,
the share of target-free frames declared present (false detections), the
frames taken to acquire after each entry (the first frame, counting the
entry frame as 1, declared present within ``divergence_px`` of the truth)
and to declare the exit (the first target-free frame declared absent,
counting the first target-free frame as 1), and the per-frame share of
runs declaring the target present.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from nnda.data.frames import FramesConfig
from nnda.filters.tbd import FILTERS, TBDConfig
from nnda.study.stats import clopper_pearson, fisher_p, mean_ci, root_mean_square
from nnda.study.tbd_chain import ChainConfig

#: the paper's divergent runs out of 100, by PTCR and filter
PAPER_DIVERGENCES = {6.5: {"apf": 3, "rs": 5}, 8.1: {"apf": 2, "rs": 3}}
#: the filters' acceleration-noise intensity in the study (pixels^2 per time unit^3), against the frames' q = 6:
#: with the frames' own q a particle's velocity moves by sqrt(q dt) = 0.49 pixels per time unit a frame, so the
#: auxiliary filter (no move step) keeps the one velocity its cloud collapsed onto and drifts off the target
#: (APF at 6.5 dB, 100 runs, seed 0: 14 divergent runs with q = 6, 0 with q = 150, 1 with q = 300)
FILTER_Q = 150.0

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class TBDFilter(BaseModel):
    """A filter of the study: ``name`` (one of `nnda.filters.tbd.FILTERS`) at ``particles`` per run."""

    model_config = _STRICT

    name: str
    particles: int = Field(ge=1)

    @model_validator(mode="after")
    def _check(self) -> TBDFilter:
        if self.name not in FILTERS:
            raise ValueError(f"unknown filter {self.name!r}; choose from {', '.join(FILTERS)}")
        return self

    @property
    def label(self) -> str:
        return f"{self.name}@{self.particles}"


#: the paper's pair (APF 5,000, RS 8,000) and, for reference, the APF's standard form and SIS at 5,000
DEFAULT_FILTERS = (TBDFilter(name="apf", particles=5000), TBDFilter(name="rs", particles=8000),
                   TBDFilter(name="apf-standard", particles=5000), TBDFilter(name="sis", particles=5000))


class ExitReentry(BaseModel):
    """The exit and re-entry scenario of the study: ``runs`` runs of ``frames`` frames at ``ptcr_db``, the
    target leaving at ``speed`` (pixels per time unit, also the scene's birth velocity sd, so the filter's
    prior covers it at one sd) after about ``exit_frames`` frames and a new one entering at ``reentry_frame``."""

    model_config = _STRICT

    runs: int = Field(20, ge=1)
    frames: int = Field(50, ge=2)
    ptcr_db: float = 8.1
    speed: float = Field(15.0, gt=0)
    exit_frames: int = Field(15, ge=1)
    reentry_frame: int = Field(30, ge=2)

    @model_validator(mode="after")
    def _check(self) -> ExitReentry:
        if self.reentry_frame > self.frames:
            raise ValueError(f"reentry_frame: {self.reentry_frame} is after the last of {self.frames} frames")
        return self


class TBDStudyConfig(BaseModel):
    """The study (module docstring): ``runs``, ``seed``, the PTCRs ``ptcr_db``, the ``scene`` (frames config;
    its ``ptcr_db`` is replaced by each of them), the ``filters``, the filter side ``tbd`` (its ``q``
    `FILTER_Q` unless the table gives one), the divergence
    rule (``divergence_px``, ``divergence_frames``), ``acquisition`` and ``steady_frames``, ``chunk_runs``
    (runs filtered at once; bounds memory), the intervals' ``confidence``, the ``exit_reentry`` scenario
    (None: not run), the matched-filter detector's ``detector_pfa``, the detect-then-track ``chain``
    (None: the detector alone) and ``max_memory_gib``, the most memory (GiB) a job or the aggregation may need
    by the study's estimate (None: the default, `nnda.study.kinds.base.MAX_MEMORY_GIB`; a bigger study is
    refused when it is planned)."""

    model_config = _STRICT

    runs: int = Field(100, ge=1)
    seed: int = Field(0, ge=0)
    ptcr_db: tuple[float, ...] = Field((6.5, 8.1), min_length=1)
    scene: FramesConfig = FramesConfig()
    filters: tuple[TBDFilter, ...] = Field(DEFAULT_FILTERS, min_length=1)
    tbd: TBDConfig = TBDConfig(q=FILTER_Q)
    divergence_px: float = Field(5.0, gt=0)
    divergence_frames: int = Field(5, ge=1)
    acquisition: int = Field(5, ge=0)
    steady_frames: int = Field(10, ge=1)
    chunk_runs: int = Field(25, ge=1)
    confidence: float = Field(0.95, gt=0, lt=1)
    exit_reentry: ExitReentry | None = ExitReentry()
    detector_pfa: float = Field(1e-4, gt=0, lt=1)
    chain: ChainConfig | None = ChainConfig()
    max_memory_gib: float | None = Field(None, gt=0)

    @field_validator("tbd", mode="before")
    @classmethod
    def _filter_q(cls, value: object) -> object:
        """A ``tbd`` table without ``q`` gets the study's `FILTER_Q` (``q`` = the scene's q for the frames' own)."""
        return {**value, "q": FILTER_Q} if isinstance(value, dict) and "q" not in value else value

    @model_validator(mode="after")
    def _check(self) -> TBDStudyConfig:
        K = self.scene.frames
        for field in ("divergence_frames", "steady_frames"):
            if getattr(self, field) > K:
                raise ValueError(f"{field}: {getattr(self, field)} is more than the scene's {K} frames")
        if self.acquisition >= K:
            raise ValueError(f"acquisition: {self.acquisition} leaves none of the scene's {K} frames")
        labels = [f.label for f in self.filters]
        if len(set(labels)) != len(labels):
            raise ValueError(f"filters: {labels} names a filter twice")
        return self


def divergence(count: int, runs: int, confidence: float) -> dict:
    """``count`` of ``runs`` with its Clopper-Pearson (exact binomial) interval."""
    low, high = clopper_pearson(count, runs, confidence)
    return {"count": count, "runs": runs, "rate": count / runs, "ci_low": low, "ci_high": high}


def fisher(a: dict, b: dict) -> float:
    """Two-sided p of Fisher's exact test of two divergence records (count of runs)."""
    return fisher_p((a["count"], a["runs"]), (b["count"], b["runs"]))


def _rmse(err2: np.ndarray, mask: np.ndarray) -> list[float | None]:
    """Per-frame RMSE (K,) over the runs where ``mask`` (R, K) holds; None for a frame with none."""
    rms = root_mean_square(np.where(mask, err2, 0.0), mask, axis=0)
    return [None if c == 0 else float(v) for v, c in zip(rms, mask.sum(axis=0))]


def score(truth: np.ndarray, position: np.ndarray, present: np.ndarray, cfg: TBDStudyConfig) -> dict:
    """The measures of one filter over R runs (module docstring): truth (R, K, 5), the filter's position
    (R, K, 2) and its decisions (R, K)."""
    on = truth[..., 4] > 0
    e = position - truth[..., [0, 2]]
    estimated = np.isfinite(e).all(axis=-1)  # a NaN position: no estimate (the chain without a track)
    e = np.where(estimated[..., None], e, np.inf)
    dist = np.hypot(e[..., 0], e[..., 1])
    lost = np.where(on, ~present | (dist > cfg.divergence_px), present)
    diverged = lost[:, -cfg.divergence_frames:].all(axis=1)
    on_est = on & estimated
    kept = on_est & ~diverged[:, None]
    steady = np.where(on_est, dist, 0.0)[:, -cfg.steady_frames:]
    with np.errstate(invalid="ignore"):  # NaN for a run without an estimate of a present target there
        per_run = steady.sum(axis=1) / on_est[:, -cfg.steady_frames:].sum(axis=1)
    after = on[:, cfg.acquisition:]
    R = truth.shape[0]
    return {
        "divergence": divergence(int(diverged.sum()), R, cfg.confidence),
        "diverged_runs": np.flatnonzero(diverged).tolist(),
        "rmse": {"x": _rmse(e[..., 0] ** 2, kept), "y": _rmse(e[..., 1] ** 2, kept),
                 "position": _rmse(dist**2, kept)},
        "rmse_all": {"x": _rmse(e[..., 0] ** 2, on_est), "y": _rmse(e[..., 1] ** 2, on_est),
                     "position": _rmse(dist**2, on_est)},
        "steady_error": mean_ci(per_run[~diverged], cfg.confidence, low=0.0),
        "steady_error_all": mean_ci(per_run, cfg.confidence, low=0.0),
        "declared_present": float(present[:, cfg.acquisition:][after].mean()) if after.any() else None,
        "false_present": float(present[~on].mean()) if (~on).any() else None,
    }


def present_share(truth: np.ndarray, present: np.ndarray, acquisition: int) -> np.ndarray:
    """Per run (R,), the share of its truth-present frames after ``acquisition`` declared present (NaN for a
    run with none): the runs' paired differences compare two estimators on the same frames."""
    on = truth[:, acquisition:, 4] > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        return (present[:, acquisition:] & on).sum(axis=1) / on.sum(axis=1)


def _frames_until(done: np.ndarray, starts: np.ndarray) -> list[int | None]:
    """For each start frame (0-based), the frames until ``done`` (K,) first holds from it on, counting the
    start frame as 1; None where it never does."""
    out = []
    for n in starts:
        hits = np.flatnonzero(done[n:])
        out.append(int(hits[0]) + 1 if hits.size else None)
    return out


def score_exit_reentry(truth: np.ndarray, position: np.ndarray, present: np.ndarray, cfg: TBDStudyConfig) -> dict:
    """The exit and re-entry measures of one filter (module docstring): truth (R, K, 5), position (R, K, 2),
    decisions (R, K)."""
    on = truth[..., 4] > 0
    dist = np.hypot(*(position - truth[..., [0, 2]]).transpose(2, 0, 1))
    hit = on & present & (dist <= cfg.divergence_px)
    first, later, exits = [], [], []
    for r in range(truth.shape[0]):
        edges = np.flatnonzero(np.diff(on[r].astype(int), prepend=0) == 1)
        acquire = _frames_until(hit[r], edges)
        first += acquire[:1]
        later += acquire[1:]
        exits += _frames_until(~present[r], np.flatnonzero(np.diff(on[r].astype(int)) == -1) + 1)

    def stat(values: list[int | None]) -> dict:
        return mean_ci(values, cfg.confidence, low=1.0) | {"never": sum(v is None for v in values),
                                                           "events": len(values)}

    return {"detection_rate": float(present[on].mean()) if on.any() else None,
            "false_detection_rate": float(present[~on].mean()) if (~on).any() else None,
            "absent_frames": int((~on).sum()),
            "first_acquire": stat(first), "reacquire": stat(later), "exit_declared": stat(exits),
            "present_by_frame": present.mean(axis=0).tolist(), "truth_present_by_frame": on.mean(axis=0).tolist()}


