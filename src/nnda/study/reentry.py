"""The ballistic re-entry filter study (Pavlov & Bruno 2003): every filter on the same Monte Carlo runs.

A study is a list of settings (a sensor, the particle counts, the filters);
each setting's ``runs`` re-entry runs (`nnda.data.reentry`, the same seed
for every setting, so the truths are shared and only the sensor noise
differs) are filtered by every filter, batched over runs
(`nnda.filters.particle.smc.run_smc`, `nnda.filters.reentry`). The study
engine runs it as the ``reentry`` job kind (`nnda.study.kinds.reentry`):
one job per (setting, filter, particle count), `run_filter`, whose records
`setting_results` turns into the setting's results.

Per filter: the RMSE of x, y, vx and vy over runs at every step, its time
average (the mean of the per-step RMSE over k = 1..K) and its
final value; the per-run position error (root mean over steps of ex^2 +
ey^2) and final position error, on which the paired comparisons rest;
the mean ESS per step and the runtime. A comparison pairs two filters on
the same runs: the mean per-run difference of position error with its
t-interval, the share of runs the second filter wins, and the ratio of
time-averaged position RMSE with a paired bootstrap interval over runs.
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from nnda.data.reentry import ReentryConfig, ReentryData
from nnda.data.sources import ReentryScenes
from nnda.filters.particle.smc import SMCConfig, run_smc
from nnda.filters.reentry import converted_kf, ekf, reentry_ssm, ukf
from nnda.study.stats import bootstrap_indices, mean_ci, percentile_interval, root_mean_square, sign_test_p

#: the particle filters and the Gaussian baselines a setting may run
PARTICLE_FILTERS = ("bootstrap", "optimal", "auxiliary", "resample-move")
BASELINES = ("ekf", "ukf", "converted-kf")
#: the prior alone (m0, Sigma0 predicted, no measurement): the reference of the "below 0.35 x prior only" bound
PRIOR = "prior"
FILTER_NAMES = PARTICLE_FILTERS + BASELINES + (PRIOR,)
#: the state components scored, in state order
COMPONENTS = ("x", "vx", "y", "vy")
#: resamples of the paired bootstrap interval of an RMSE ratio
BOOTSTRAP_RESAMPLES = 2000

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ReentrySetting(BaseModel):
    """One sensor and what runs on it: ``sigma_r`` (m), ``sigma_eps`` (rad), ``particles`` (each particle
    filter runs at every count), ``filters`` (names of FILTER_NAMES)."""

    model_config = _STRICT

    name: str = Field(min_length=1)
    sigma_r: float = Field(gt=0)
    sigma_eps: float = Field(gt=0)
    particles: tuple[int, ...] = (4000,)
    filters: tuple[str, ...] = FILTER_NAMES

    @model_validator(mode="after")
    def _check(self) -> ReentrySetting:
        unknown = [f for f in self.filters if f not in FILTER_NAMES]
        if unknown:
            raise ValueError(f"unknown filter(s) {unknown}; choose from {', '.join(FILTER_NAMES)}")
        if any(n < 1 for n in self.particles):
            raise ValueError(f"particles: every count must be >= 1, got {list(self.particles)}")
        return self


#: the paper's Monte Carlo setting, the particle sweep on the same data, the precise sensor
DEFAULT_SETTINGS = (
    ReentrySetting(name="paper", sigma_r=200.0, sigma_eps=0.017, particles=(4000,)),
    ReentrySetting(name="sweep", sigma_r=200.0, sigma_eps=0.017, particles=(1000, 20000),
                   filters=("bootstrap", "optimal")),
    ReentrySetting(name="precise", sigma_r=5.0, sigma_eps=0.0005, particles=(1000,)),
)


class ReentryStudyConfig(BaseModel):
    """The study: ``runs`` Monte Carlo runs of ``steps`` steps (cut at ground impact), ``seed``, the data
    ``mode``, the settings, the particle filters' ``resampling`` and ``ess_threshold`` (None: every step, the
    paper), the converted KF's process noise ``converted_kf_sigma_w`` (m s^-3/2), ``chunk_particles`` (runs
    x particles filtered at once; bounds memory), the intervals' ``confidence`` and ``max_memory_gib``, the most
    memory (GiB) a job or the aggregation may need by the study's estimate (None: the default,
    `nnda.study.kinds.base.MAX_MEMORY_GIB`; a bigger study is refused when it is planned)."""

    model_config = _STRICT

    runs: int = Field(100, ge=1)
    steps: int = Field(55, ge=1)
    seed: int = Field(0, ge=0)
    mode: Literal["polar", "gaussian"] = "polar"
    settings: tuple[ReentrySetting, ...] = DEFAULT_SETTINGS
    resampling: str = "multinomial"
    ess_threshold: float | None = Field(None, gt=0, le=1)
    converted_kf_sigma_w: float = Field(30.0, ge=0)
    chunk_particles: int = Field(1_000_000, ge=1)
    confidence: float = Field(0.95, gt=0, lt=1)
    max_memory_gib: float | None = Field(None, gt=0)


def _label(name: str, n: int | None) -> str:
    return name if n is None else f"{name}@{n}"


def _run_filter(name: str, n: int | None, data: ReentryData, cfg: ReentryStudyConfig,
                seed: np.random.SeedSequence) -> tuple[np.ndarray, np.ndarray | None, float]:
    """Estimates (R, K, 4), the mean ESS trace (R, K) or None, and the seconds taken."""
    t0 = time.perf_counter()
    if name in BASELINES + (PRIOR,):
        est = {"ekf": ekf, "ukf": ukf, "converted-kf": lambda d: converted_kf(d, cfg.converted_kf_sigma_w),
               PRIOR: lambda d: ekf(d, update=False)}[name](data)
        return est.mean, None, time.perf_counter() - t0
    smc = SMCConfig(name, n, resampling=cfg.resampling, ess_threshold=cfg.ess_threshold)
    per_chunk = max(1, cfg.chunk_particles // n)
    rng = np.random.default_rng(seed)
    means, ess = [], []
    for start in range(0, data.z.shape[0], per_chunk):
        out = run_smc(reentry_ssm(data.take(slice(start, start + per_chunk))), smc, rng)
        means.append(out.mean)
        ess.append(out.ess)
    return np.concatenate(means), np.concatenate(ess), time.perf_counter() - t0


def _scores(mean: np.ndarray, truth: np.ndarray) -> dict:
    """RMSE per step, time-averaged and final per component; per-run position errors (time-averaged and
    final), their median and the worst final one (a diverged run shows there)."""
    err = mean - truth[:, 1:]
    rmse = root_mean_square(err**2, axis=0)  # (K, 4)
    pos2 = err[..., 0] ** 2 + err[..., 2] ** 2  # (R, K)
    position = root_mean_square(pos2, axis=0)
    per_run, final = root_mean_square(pos2, axis=1), np.sqrt(pos2[:, -1])
    return {
        "rmse": {c: rmse[:, i].tolist() for i, c in enumerate(COMPONENTS)} | {"position": position.tolist()},
        "time_avg": {c: float(rmse[:, i].mean()) for i, c in enumerate(COMPONENTS)} | {
            "position": float(position.mean())},
        "final": {c: float(rmse[-1, i]) for i, c in enumerate(COMPONENTS)} | {"position": float(position[-1])},
        "per_run_position": per_run.tolist(),
        "per_run_final_position": final.tolist(),
        "median_run_position": float(np.median(per_run)),
        "worst_final_position": float(final.max()),
    }


def _ratio_interval(num: np.ndarray, den: np.ndarray, confidence: float, seed: int) -> tuple[float, float]:
    """Paired bootstrap interval over runs of the ratio of time-averaged position RMSE; num, den (R, K) the
    squared position errors of the two filters."""
    idx = bootstrap_indices(seed, num.shape[0], BOOTSTRAP_RESAMPLES)
    ratio = root_mean_square(num[idx], axis=1).mean(axis=1) / root_mean_square(den[idx], axis=1).mean(axis=1)
    return percentile_interval(ratio, confidence)


def compare(a: str, b: str, errors: dict[str, np.ndarray], scores: dict[str, dict], confidence: float,
            seed: int) -> dict:
    """Filter ``a`` against ``b`` on the same runs: per-run differences a - b of position error (time-averaged
    and final) with t-intervals and their median, the share of runs b wins with the two-sided sign test's p
    (robust to the few runs that dominate an RMSE), and the RMSE ratio a / b with a bootstrap interval."""
    da = np.array(scores[a]["per_run_position"]) - np.array(scores[b]["per_run_position"])
    df = np.array(scores[a]["per_run_final_position"]) - np.array(scores[b]["per_run_final_position"])
    low, high = _ratio_interval(errors[a], errors[b], confidence, seed)
    ratio = scores[a]["time_avg"]["position"] / scores[b]["time_avg"]["position"]
    return {"a": a, "b": b, "difference": mean_ci(da, confidence), "final_difference": mean_ci(df, confidence),
            "median_difference": float(np.median(da)), "b_better": float((da > 0).mean()),
            "sign_test_p": sign_test_p(da),
            "ratio": {"mean": ratio, "ci_low": low, "ci_high": high}}


def _pairs(labels: list[str]) -> list[tuple[str, str]]:
    """The comparisons of a setting: at each particle count, bootstrap against each other particle filter;
    the Gaussian baselines against the largest-count optimal filter (or bootstrap)."""
    pairs = []
    counts = sorted({int(label.split("@")[1]) for label in labels if "@" in label})
    for n in counts:
        pairs += [(f"bootstrap@{n}", f"{f}@{n}") for f in PARTICLE_FILTERS[1:]
                  if f"bootstrap@{n}" in labels and f"{f}@{n}" in labels]
    best = next((f"{f}@{counts[-1]}" for f in ("optimal", "bootstrap") if counts and f"{f}@{counts[-1]}" in labels),
                None)
    if best is not None:
        pairs += [(best, b) for b in BASELINES if b in labels]
    return pairs


def source(setting: ReentrySetting, cfg: ReentryStudyConfig) -> ReentryScenes:
    """Where a setting's runs come from: ``cfg.runs`` runs of its sensor, drawn with the study's seed (every
    setting shares the truths; only the sensor noise differs)."""
    config = ReentryConfig(sigma_r=setting.sigma_r, sigma_eps=setting.sigma_eps, steps=cfg.steps, mode=cfg.mode)
    return ReentryScenes(setting.name, f"re-entry runs, sigma_r {setting.sigma_r:g} m, sigma_eps "
                                       f"{setting.sigma_eps:g} rad", config)


def filter_entries(setting: ReentrySetting) -> list[tuple[int, str, int | None]]:
    """(index in the setting's filters, filter, particle count or None) of every filter run of a setting, in
    report order."""
    return [(fi, name, n) for fi, name in enumerate(setting.filters)
            for n in (setting.particles if name in PARTICLE_FILTERS else (None,))]


def run_filter(setting: ReentrySetting, index: int, fi: int, name: str, n: int | None,
               cfg: ReentryStudyConfig) -> dict:
    """One filter of setting ``index`` on the setting's runs: its scores (`_scores`), the ESS of a particle
    filter, each run's squared position error per step (for the paired comparisons), the runs' steps and
    impacts, and its runtime (s) under ``timing``."""
    data = source(setting, cfg).load(0, cfg.runs, cfg.seed)
    mean, ess, seconds = _run_filter(name, n, data, cfg, np.random.SeedSequence([cfg.seed, index, fi, n or 0]))
    entry = {"filter": name, "particles": n} | _scores(mean, data.truth)
    if ess is not None:
        entry["ess_mean"] = ess.mean(axis=0).tolist()
        entry["ess"] = {"mean": float(ess.mean()), "min": float(ess.min())}
    err = mean - data.truth[:, 1:]
    return {"setting": setting.name, "label": _label(name, n), "entry": entry, "steps": data.steps,
            "impact_steps": sorted(set(data.impact.tolist()) - {0}),
            "position_error2": (err[..., 0] ** 2 + err[..., 2] ** 2).tolist(), "timing": {"runtime_s": seconds}}


def setting_results(setting: ReentrySetting, cfg: ReentryStudyConfig, records: list[dict]) -> dict:
    """A setting's results from its filters' records (in `filter_entries` order): every filter's entry (with
    its runtime) and the paired comparisons."""
    filters = {r["label"]: r["entry"] | r["timing"] for r in records}
    errors = {r["label"]: np.asarray(r["position_error2"]) for r in records}
    comparisons = [compare(a, b, errors, filters, cfg.confidence, cfg.seed + i)
                   for i, (a, b) in enumerate(_pairs(list(filters)))]
    return {"name": setting.name, "sigma_r": setting.sigma_r, "sigma_eps": setting.sigma_eps,
            "runs": cfg.runs, "steps": records[0]["steps"], "impact_steps": records[0]["impact_steps"],
            "filters": filters, "comparisons": comparisons}
