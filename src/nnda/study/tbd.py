"""The track-before-detect study (Bruno, Araújo & Pavlov): every filter on the same Monte Carlo frames.

At each PTCR, ``runs`` runs of ``frames`` frames (`nnda.data.frames`, run r
drawn from (seed, r) at every PTCR, so the truths and the clutter are
shared and only the amplitude differs) are filtered by every filter
(`nnda.filters.tbd.run_tbd`), in blocks of ``chunk_runs`` runs. The study
engine runs it as the ``tbd`` job kind (`nnda.study.kinds.tbd`): one job
per (setting, estimator, block of runs), `run_block`; `assemble` joins an
estimator's blocks and `ptcr_results`, `exit_reentry_results` and
`study_results` score them.

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

import time

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from nnda.data.frames import FramesConfig, simulate
from nnda.filters.tbd import FILTERS, TBDConfig, run_tbd, tbd_model
from nnda.study.stats import clopper_pearson, fisher_p, mean_ci, root_mean_square
from nnda.study.tbd_chain import ChainConfig, frame_detections, run_chain

#: the paper's divergent runs out of 100, by PTCR and filter
PAPER_DIVERGENCES = {6.5: {"apf": 3, "rs": 5}, 8.1: {"apf": 2, "rs": 3}}

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
    its ``ptcr_db`` is replaced by each of them), the ``filters``, the filter side ``tbd``, the divergence
    rule (``divergence_px``, ``divergence_frames``), ``acquisition`` and ``steady_frames``, ``chunk_runs``
    (runs filtered at once; bounds memory), the intervals' ``confidence``, the ``exit_reentry`` scenario
    (None: not run), the matched-filter detector's ``detector_pfa`` and the detect-then-track ``chain``
    (None: the detector alone)."""

    model_config = _STRICT

    runs: int = Field(100, ge=1)
    seed: int = Field(0, ge=0)
    ptcr_db: tuple[float, ...] = Field((6.5, 8.1), min_length=1)
    scene: FramesConfig = FramesConfig()
    filters: tuple[TBDFilter, ...] = Field(DEFAULT_FILTERS, min_length=1)
    tbd: TBDConfig = TBDConfig()
    divergence_px: float = Field(5.0, gt=0)
    divergence_frames: int = Field(5, ge=1)
    acquisition: int = Field(5, ge=0)
    steady_frames: int = Field(10, ge=1)
    chunk_runs: int = Field(25, ge=1)
    confidence: float = Field(0.95, gt=0, lt=1)
    exit_reentry: ExitReentry | None = ExitReentry()
    detector_pfa: float = Field(1e-4, gt=0, lt=1)
    chain: ChainConfig | None = ChainConfig()

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


def scenes(cfg: TBDStudyConfig) -> list[tuple[str, FramesConfig, int]]:
    """(name, frames config, runs) of every setting in index order: each PTCR, then the exit and re-entry
    scenario when the study runs it."""
    out = [(f"ptcr-{p:g}", cfg.scene.model_copy(update={"ptcr_db": p}), cfg.runs) for p in cfg.ptcr_db]
    er = cfg.exit_reentry
    if er is not None:
        out.append(("exit-reentry", cfg.scene.model_copy(update={
            "ptcr_db": er.ptcr_db, "frames": er.frames, "scenario": "exit-reentry", "exit_frames": er.exit_frames,
            "reentry_frame": er.reentry_frame, "exit_speed": er.speed, "birth_velocity_sd": er.speed}), er.runs))
    return out


def estimators(cfg: TBDStudyConfig) -> list[str]:
    """What runs on every block of a setting: the detector, each chain tracker ("chain:<name>"), each filter
    (its label)."""
    chain = [f"chain:{name}" for name in cfg.chain.trackers] if cfg.chain is not None else []
    return ["detector", *chain, *(f.label for f in cfg.filters)]


def run_block(cfg: TBDStudyConfig, index: int, scene: FramesConfig, start: int, count: int, estimator: str) -> dict:
    """One estimator on runs ``start``..``start + count - 1`` of setting ``index`` (frames drawn from the seed and
    the run, so a block is the same alone as among all runs). The detector's record holds the block's truth
    (count, K, 5) and its counts (`detector_counts`); a chain tracker's and a filter's their position
    (count, K, 2; NaN without an estimate) and decisions (count, K), a filter's also P(z = 0) and its
    likelihood evaluations; every record its seconds under ``timing``."""
    fs = simulate(scene, count, cfg.seed, first_run=start)
    model = tbd_model(fs, cfg.tbd)
    t0 = time.perf_counter()
    if estimator == "detector":
        hits = frame_detections(model, cfg.detector_pfa)
        seconds = time.perf_counter() - t0
        return {"truth": fs.truth.tolist(), "counts": detector_counts(fs.truth, hits, cfg.divergence_px).tolist(),
                "timing": {"seconds": seconds}}
    if estimator.startswith("chain:"):
        out = run_chain(model, frame_detections(model, cfg.detector_pfa), estimator[6:], cfg.chain, cfg.detector_pfa)
        return {"position": out.position.tolist(), "present": out.present.tolist(), "settings": out.settings,
                "timing": {"seconds": out.seconds}}
    fi, f = next((i, f) for i, f in enumerate(cfg.filters) if f.label == estimator)
    rng = np.random.default_rng(np.random.SeedSequence([cfg.seed, index, fi, start]))
    out = run_tbd(model, f.name, f.particles, rng)
    return {"position": out.position.tolist(), "present": out.present.tolist(), "p_absent": out.p_absent.tolist(),
            "evaluations": out.evaluations_per_frame * fs.runs, "timing": {"seconds": out.seconds}}


def assemble(cfg: TBDStudyConfig, scene: FramesConfig, runs: int, blocks: dict[str, list[dict]]
             ) -> tuple[np.ndarray, dict]:
    """The truth (R, K, 5) and, per filter label, its position (R, K, 2), decisions (R, K), P(z = 0) (R, K) and
    cost, under "detector" the detector's counts and under "chain" each chain tracker's position, decisions
    and cost, from every estimator's ``blocks`` (its records in block order)."""
    def stack(name: str, key: str, dtype=float) -> np.ndarray:
        return np.concatenate([np.asarray(b[key], dtype=dtype) for b in blocks[name]])

    frames = runs * scene.frames
    detector_s = sum(b["timing"]["seconds"] for b in blocks["detector"])
    counts = np.zeros(3)
    for b in blocks["detector"]:
        counts += np.asarray(b["counts"])
    got = {}
    for f in cfg.filters:
        seconds = sum(b["timing"]["seconds"] for b in blocks[f.label])
        evaluations = 0.0
        for b in blocks[f.label]:
            evaluations += b["evaluations"]
        got[f.label] = {"position": stack(f.label, "position"), "present": stack(f.label, "present", bool),
                        "p_absent": stack(f.label, "p_absent"), "filter": f.name, "particles": f.particles,
                        "evaluations_per_frame": evaluations / runs, "seconds": seconds,
                        "ms_per_frame": 1e3 * seconds / (runs * scene.frames)}
    got["detector"] = {"pfa": cfg.detector_pfa, "p_detection": counts[0] / max(counts[1], 1),
                       "false_per_frame": counts[2] / frames, "correlations_per_frame": _correlations(scene),
                       "seconds": detector_s, "ms_per_frame": 1e3 * detector_s / frames}
    chain = {}
    for name in (cfg.chain.trackers if cfg.chain is not None else ()):
        key = f"chain:{name}"
        seconds = sum(b["timing"]["seconds"] for b in blocks[key])
        chain[name] = {"tracker": name, "settings": blocks[key][-1]["settings"], "seconds": seconds,
                       "ms_per_frame": 1e3 * (seconds + detector_s) / frames,
                       "position": stack(key, "position"), "present": stack(key, "present", bool)}
    got["chain"] = chain
    return stack("detector", "truth"), got


def _correlations(scene: FramesConfig) -> int:
    """Template correlations of the matched filter per frame: every aspect at every extended-grid position."""
    h = scene.template_half
    return len(scene.aspects) * (scene.rows + 2 * h) * (scene.cols + 2 * h)


def detector_counts(truth: np.ndarray, hits: list[np.ndarray], near_px: float) -> np.ndarray:
    """[frames with a detection within ``near_px`` of the present target, truth-present frames, other
    detections] of the per-frame detections ``hits`` (K arrays (n, 5) [run, row, column, ...]) of runs
    with ``truth`` (R, K, 5)."""
    out = np.zeros(3)
    for k, h in enumerate(hits):
        run = h[:, 0].astype(np.int64)
        t = truth[run, k]
        near = (t[:, 4] > 0) & (np.hypot(h[:, 1] - t[:, 0], h[:, 2] - t[:, 2]) <= near_px)
        present = truth[:, k, 4] > 0
        out += [np.isin(np.flatnonzero(present), run[near]).sum(), present.sum(), (~near).sum()]
    return out


def _chain_entry(c: dict) -> dict:
    return {k: c[k] for k in ("tracker", "settings", "seconds", "ms_per_frame")}


def _cost(g: dict) -> dict:
    return {k: g[k] for k in ("filter", "particles", "evaluations_per_frame", "seconds", "ms_per_frame")} | {
        "p_absent_mean": g["p_absent"].mean(axis=0).tolist()}


def ptcr_results(cfg: TBDStudyConfig, scene: FramesConfig, truth: np.ndarray, got: dict) -> dict:
    """Every estimator at one PTCR scored (`score`), compared pairwise and against the paper (Fisher), from
    `assemble`'s truth and estimates."""
    ptcr = scene.ptcr_db
    detector, raw = got.pop("detector"), got.pop("chain")
    filters = {label: _cost(g) | score(truth, g["position"], g["present"], cfg) for label, g in got.items()}
    chain = {name: _chain_entry(c) | score(truth, c["position"], c["present"], cfg) for name, c in raw.items()}
    labels = list(filters)
    pairs = [{"a": a, "b": b, "fisher_p": fisher(filters[a]["divergence"], filters[b]["divergence"])}
             for i, a in enumerate(labels) for b in labels[i + 1:]]
    paper = {}
    for label, entry in filters.items():
        count = PAPER_DIVERGENCES.get(ptcr, {}).get(entry["filter"])
        if count is not None:
            theirs = divergence(count, 100, cfg.confidence)
            paper[label] = {"divergence": theirs, "fisher_p": fisher(entry["divergence"], theirs)}
    share = {key: _present_share(truth, g["present"], cfg.acquisition) for key, g in (*got.items(), *raw.items())}
    chain_vs = [{"chain": name, "filter": label, "fisher_p": fisher(c["divergence"], f["divergence"]),
                 "present_difference": mean_ci(share[name] - share[label], cfg.confidence, low=-1.0, high=1.0)}
                for name, c in chain.items() for label, f in filters.items()]
    return {"ptcr_db": ptcr, "runs": cfg.runs, "frames": scene.frames, "detector": detector,
            "truth_present_all_frames": int((truth[..., 4] > 0).all(axis=1).sum()),
            "filters": filters, "pairs": pairs, "paper": paper, "chain": chain, "chain_vs_filters": chain_vs}


def _present_share(truth: np.ndarray, present: np.ndarray, acquisition: int) -> np.ndarray:
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


def exit_reentry_results(cfg: TBDStudyConfig, truth: np.ndarray, got: dict) -> dict:
    """The exit and re-entry scenario (``cfg.exit_reentry``) scored for every filter and chain tracker, from
    `assemble`'s truth and estimates."""
    er = cfg.exit_reentry
    got.pop("detector")
    chain = got.pop("chain")
    return {"ptcr_db": er.ptcr_db, "runs": er.runs, "frames": er.frames, "reentry_frame": er.reentry_frame,
            "speed": er.speed,
            "filters": {label: _cost(g) | score_exit_reentry(truth, g["position"], g["present"], cfg)
                        for label, g in got.items()},
            "chain": {name: _chain_entry(c) | score_exit_reentry(truth, c["position"], c["present"], cfg)
                      for name, c in chain.items()}}


def study_results(cfg: TBDStudyConfig, settings: list[dict], exit_reentry: dict | None, runtime_s: float) -> dict:
    """The study's results document from every PTCR's results (`ptcr_results`) and the exit and re-entry
    scenario's, with each filter's divergence compared across the PTCRs (Fisher)."""
    across = []
    for f in cfg.filters:
        for i, a in enumerate(settings):
            for b in settings[i + 1:]:
                da, db = a["filters"][f.label]["divergence"], b["filters"][f.label]["divergence"]
                across.append({"filter": f.label, "a": a["ptcr_db"], "b": b["ptcr_db"], "fisher_p": fisher(da, db)})
    return {"config": cfg.model_dump(mode="json"), "settings": settings, "across_ptcr": across,
            "exit_reentry": exit_reentry, "runtime_s": runtime_s}


#: the file, format and version of the study's snapshot of run 0 (`snapshot`)
SNAPSHOT_FILE, SNAPSHOT_FORMAT, SNAPSHOT_VERSION = "tbd_snapshot.json", "nnda.tbd-snapshot", 1
#: the frames (1-based) and the number of heaviest present particles the study keeps of run 0 for a figure
SNAPSHOT_FRAMES = (1, 2, 5)
SNAPSHOT_PARTICLES = 400


def snapshot(cfg: TBDStudyConfig) -> dict:
    """Run 0 at the first PTCR through the first filter (its seed as in the study's first block): at frames
    `SNAPSHOT_FRAMES` and the last, the frame (rows x cols), the `SNAPSHOT_PARTICLES` heaviest present particles'
    [row, column], the estimate, P(z = 0) and the truth, for the report's figure."""
    f, scene = cfg.filters[0], cfg.scene.model_copy(update={"ptcr_db": cfg.ptcr_db[0]})
    fs = simulate(scene, 1, cfg.seed)
    model = tbd_model(fs, cfg.tbd)
    model.snapshots = []
    out = run_tbd(model, f.name, f.particles, np.random.default_rng(np.random.SeedSequence([cfg.seed, 0, 0, 0])))
    frames = []
    for n in sorted({n for n in SNAPSHOT_FRAMES if n <= scene.frames} | {scene.frames}):
        W, x = model.snapshots[n - 1]
        present = np.flatnonzero(x[0, :, 4] > 0)
        top = present[np.argsort(W[0, present])[::-1][:SNAPSHOT_PARTICLES]]
        frames.append({"frame": n, "image": fs.frames[0, n - 1].tolist(), "particles": x[0, top][:, [0, 2]].tolist(),
                       "estimate": out.position[0, n - 1].tolist(), "p_absent": float(out.p_absent[0, n - 1]),
                       "truth": fs.truth[0, n - 1, [0, 2]].tolist()})
    return {"format": SNAPSHOT_FORMAT, "format_version": SNAPSHOT_VERSION, "ptcr_db": scene.ptcr_db,
            "filter": f.label, "particles_shown": SNAPSHOT_PARTICLES, "frames": frames}
