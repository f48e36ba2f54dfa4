"""The track-before-detect study's runs: its settings, one job's work on a block of runs, and the results
from the jobs' records (Bruno, Araújo & Pavlov; the measures and the configs are `nnda.study.tbd`'s).

The study engine runs it as the ``tbd`` job kind (`nnda.study.kinds.tbd`):
one job per (setting, estimator, block of runs), `run_block`; `assemble`
joins an estimator's blocks and `ptcr_results`, `exit_reentry_results` and
`study_results` score them; `snapshot` keeps run 0's frames and particles
for the report's figure.
"""

from __future__ import annotations

import time

import numpy as np

from nnda.data.frames import FramesConfig
from nnda.data.sources import FrameScenes
from nnda.filters.tbd import run_tbd, tbd_model
from nnda.study.stats import mean_ci
from nnda.study.tbd import (
    PAPER_DIVERGENCES,
    TBDStudyConfig,
    divergence,
    fisher,
    present_share,
    score,
    score_exit_reentry,
)
from nnda.study.tbd_chain import frame_detections, run_chain


def scenes(cfg: TBDStudyConfig) -> list[tuple[FrameScenes, int]]:
    """The frames of every setting in index order (each PTCR, then the exit and re-entry scenario when the study
    runs it) and its runs."""
    out = [(FrameScenes(f"ptcr-{p:g}", f"frames at {p:g} dB", cfg.scene.model_copy(update={"ptcr_db": p})),
            cfg.runs) for p in cfg.ptcr_db]
    er = cfg.exit_reentry
    if er is not None:
        out.append((FrameScenes("exit-reentry", f"the exit and re-entry scenario at {er.ptcr_db:g} dB",
                                cfg.scene.model_copy(update={
                                    "ptcr_db": er.ptcr_db, "frames": er.frames, "scenario": "exit-reentry",
                                    "exit_frames": er.exit_frames, "reentry_frame": er.reentry_frame,
                                    "exit_speed": er.speed, "birth_velocity_sd": er.speed})), er.runs))
    return out


def estimators(cfg: TBDStudyConfig) -> list[str]:
    """What runs on every block of a setting: the detector, each chain tracker ("chain:<name>"), each filter
    (its label)."""
    chain = [f"chain:{name}" for name in cfg.chain.trackers] if cfg.chain is not None else []
    return ["detector", *chain, *(f.label for f in cfg.filters)]


def run_block(cfg: TBDStudyConfig, index: int, source: FrameScenes, start: int, count: int, estimator: str) -> dict:
    """One estimator on runs ``start``..``start + count - 1`` of setting ``index`` (frames drawn from the seed and
    the run, so a block is the same alone as among all runs). The detector's record holds the block's truth
    (count, K, 5) and its counts (`detector_counts`); a chain tracker's and a filter's their position
    (count, K, 2; NaN without an estimate) and decisions (count, K), a filter's also P(z = 0) and its
    likelihood evaluations; every record its seconds under ``timing``."""
    fs = source.load(start, count, cfg.seed)
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
    share = {key: present_share(truth, g["present"], cfg.acquisition) for key, g in (*got.items(), *raw.items())}
    chain_vs = [{"chain": name, "filter": label, "fisher_p": fisher(c["divergence"], f["divergence"]),
                 "present_difference": mean_ci(share[name] - share[label], cfg.confidence, low=-1.0, high=1.0)}
                for name, c in chain.items() for label, f in filters.items()]
    return {"ptcr_db": ptcr, "runs": cfg.runs, "frames": scene.frames, "detector": detector,
            "truth_present_all_frames": int((truth[..., 4] > 0).all(axis=1).sum()),
            "filters": filters, "pairs": pairs, "paper": paper, "chain": chain, "chain_vs_filters": chain_vs}


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
    config = cfg.model_dump(mode="json", exclude={"max_memory_gib"})  # a limit, not a setting of the results
    return {"config": config, "settings": settings, "across_ptcr": across, "exit_reentry": exit_reentry,
            "runtime_s": runtime_s}


#: the file, format and version of the study's snapshot of run 0 (`snapshot`)
SNAPSHOT_FILE, SNAPSHOT_FORMAT, SNAPSHOT_VERSION = "tbd_snapshot.json", "nnda.tbd-snapshot", 1
#: the frames (1-based) and the number of heaviest present particles the study keeps of run 0 for a figure
SNAPSHOT_FRAMES = (1, 2, 5)
SNAPSHOT_PARTICLES = 400


def snapshot(cfg: TBDStudyConfig) -> dict:
    """Run 0 at the first PTCR through the first filter (its seed as in the study's first block): at frames
    `SNAPSHOT_FRAMES` and the last, the frame (rows x cols), the `SNAPSHOT_PARTICLES` heaviest present particles'
    [row, column], the estimate, P(z = 0) and the truth, for the report's figure."""
    f, (source, _) = cfg.filters[0], scenes(cfg)[0]
    scene, fs = source.config, source.load(0, 1, cfg.seed)
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
