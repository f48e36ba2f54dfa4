"""The conventional chain that Bruno, Araújo & Pavlov argue against: detect in every frame, then track the
detections with nnda's contact trackers (GNN, MHT), for the track-before-detect study to
score beside its particle filters.

    model = tbd_model(fs, TBDConfig())                 # R runs of K frames (`nnda.filters.tbd`)
    hits = frame_detections(model, pfa=1e-4)           # K arrays (n_k, 5) [run, row, column, aspect, t]
    out = run_chain(model, hits, "gnn", ChainConfig(), pfa=1e-4)
    out.present (R, K)   out.position (R, K, 2)   out.tracks (R, K) confirmed tracks   out.seconds

Detections: `nnda.filters.frame_likelihood.detections` on each frame's
matched-filter statistics (the GMRF parameters as the filters take them,
known or estimated per frame), pixel positions (row, column).

Each run is one sweep of one Cartesian position sensor per frame
(`nnda.data.scenario.Sensor`, kind "position", as the pedestrian ground
radar): pixels are its unit of length (x = row, y = column) and the
paper's frame interval dt its scan period (time units for seconds), so
speeds are pixels per time unit as in `nnda.data.frames`. The scans go to
the tracker as they would from a dataset (`nnda.data.dataset.Scan`), and
the tracker is the registry's (`nnda.tracking.registry.TRACKERS`) with its
config validated as `make_tracker` does, given its per-track filter. What
the radar defaults (metres, 2 s scans) would get wrong is set from the
frame model and the detector instead (`tracker_params`, `track_filter`):

- sensor coverage: a disk about the frame's centre reaching the corners
  of the extended grid (positions a template can touch), so no detection
  is outside it and a track leaves coverage only when it leaves the frame;
- measurement noise: ``measurement_sd`` pixels per axis. Detections lie on
  the pixel grid, so quantisation alone gives 1/sqrt(12) = 0.29 px; the
  clutter moves the statistic's peak within the 7 x 7 template's core, and
  the detections within 5 px of the target are off by 0.76 (8.1 dB) to 0.83
  px (6.5 dB) per axis (seed 0, 25 runs): the default 0.8 px is that;
- motion: one nearly-constant-velocity model (the frames' truth has no
  turns), its acceleration noise sigma_q = sqrt(q / dt), so the velocity
  increment of a scan, sigma_q^2 dt^2, equals the frames' q dt (nnda's CV
  is discrete white-noise acceleration; its position term dt^4 / 4
  sigma_q^2 = q dt^3 / 4 is the frames' q dt^3 / 3 within 25%, 0.01 px);
- initiation window: speeds 0 to ``speed_sds`` birth velocity sds
  (the speed of a birth is Rayleigh: beyond 4 sd with probability e^-8);
  the speed sanity rule above the window's top by ``speed_sds`` sds of a
  two-point start's velocity (sqrt(2) measurement_sd / dt per axis), so it
  deletes no fresh track of a real target; no position-sd limit (a frame
  is ~100 px wide: the M/N misses end a coasting track first);
- MHT's clutter density: the detector's false-alarm rate per pixel, A pfa
  for A aspects (the union bound over a position's aspects; the 3 x 3 peak
  rule keeps fewer: 1.7e-4 per pixel measured against the bound's 4e-4 at
  pfa 1e-4, a factor that moves a track score by < 1); its detection
  probability: the matched filter's at the target's own position and
  aspect, mean over aspects of Phi(sqrt(rho_a) / sigma_c - Phi^-1(1 - pfa))
  (`detection_probability`), clipped to [`PD_FLOOR`, `PD_CEILING`].

The life cycle follows the detector's probability of detection P_D
(`detection_probability`; 0.43 at 6.5 dB, 0.69 at 8.1 dB at pfa 1e-4):
confirmation `CONFIRM_M` of `CONFIRM_N` (the radar's 3 of 4 confirms a
target seen in 43% of frames too rarely, while clutter this sparse, 3
detections a frame over ~18,000 pixels, meets a gate of a few pixels
twice in 4 frames almost never: 0 of 850 target-free frames declared
present at 2/4 or 3/4), and a confirmed track deleted after the fewest
consecutive misses j with (1 - P_D)^j <= `COAST_RISK` (9 at 6.5 dB, 4 at
8.1 dB). Gates stay the trackers' (chi-square 9.21). ``params`` overrides
any tracker field (its ``lifecycle`` merged field by field).

The estimate of a frame: the target is declared present when the tracker
reports a confirmed track, and its position is that of the confirmed track
that has used the most detections so far (ties: the oldest); a frame
without a confirmed track has a NaN position. The study (`nnda.study.tbd`) scores these as it scores
the particle filters' decisions and conditional means.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.special import ndtr, ndtri
from threadpoolctl import threadpool_limits

from nnda.data.dataset import Scan
from nnda.data.frames import FramesConfig
from nnda.data.scenario import Clutter, Sensor
from nnda.errors import validated
from nnda.filters.frame_likelihood import FrameLikelihood, detections
from nnda.filters.imm import IMM
from nnda.filters.measurement import PositionMeasurement
from nnda.filters.motion import ConstantVelocity
from nnda.filters.tbd import TBDModel
from nnda.tracking.lifecycle import THESIS_LIFECYCLE
from nnda.tracking.output import CONFIRMED, NO_CONTACT
from nnda.tracking.registry import TRACKERS

#: the detect-then-track chain's trackers (contact trackers taking a per-track filter)
CHAIN_TRACKERS = ("gnn", "mht")
#: measurement noise (pixels per axis) of a detection, module docstring
MEASUREMENT_SD_PX = 0.8
#: the initiation window's top and the speed rule's margin, in sds (module docstring)
SPEED_SDS = 4.0
#: MHT's detection probability is kept within these (its config needs 0 < pd < 1)
PD_FLOOR, PD_CEILING = 0.05, 0.99
#: M/N confirmation of the chain's tracks (module docstring)
CONFIRM_M, CONFIRM_N = 2, 4
#: a confirmed track is deleted after the fewest misses in a row a detected target has at most this chance of
COAST_RISK = 0.01

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ChainConfig(BaseModel):
    """The chain (module docstring): its ``trackers`` (of `CHAIN_TRACKERS`), the detections' ``measurement_sd``
    (pixels per axis), ``speed_sds`` and per-tracker ``params`` overriding the derived configs."""

    model_config = _STRICT

    trackers: tuple[str, ...] = Field(CHAIN_TRACKERS, min_length=1)
    measurement_sd: float = Field(MEASUREMENT_SD_PX, gt=0)
    speed_sds: float = Field(SPEED_SDS, gt=0)
    params: dict[str, dict[str, Any]] = {}

    @model_validator(mode="after")
    def _check(self) -> ChainConfig:
        for name in (*self.trackers, *self.params):
            if name not in CHAIN_TRACKERS:
                raise ValueError(f"unknown chain tracker {name!r}; choose from {', '.join(CHAIN_TRACKERS)}")
        if len(set(self.trackers)) != len(self.trackers):
            raise ValueError(f"trackers: {list(self.trackers)} names a tracker twice")
        return self


@dataclass(frozen=True)
class ChainResult:
    """A tracker's estimate over R runs of K frames: ``present`` (R, K) a confirmed track reported,
    ``position`` (R, K, 2) the best confirmed track's [row, column] (NaN where none), ``tracks`` (R, K)
    the confirmed tracks reported, ``seconds`` the tracker's steps and the ``settings`` derived from the
    frame model: the tracker's ``params``, the per-track filter's CV ``sigma_q`` and ``measurement_sd``
    (pixels, time units), the ``detection_probability`` the life cycle assumed."""

    present: np.ndarray
    position: np.ndarray
    tracks: np.ndarray
    seconds: float
    settings: dict[str, Any]


def frame_detections(model: TBDModel, pfa: float) -> list[np.ndarray]:
    """Every frame's matched-filter detections (`nnda.filters.frame_likelihood.detections`) of every run: K
    arrays (n_k, 5) [run, row, column, aspect, t], on the model's differential frames."""
    lik = model.likelihood
    out = []
    for k in range(1, model.steps + 1):
        d_pad, bh, bv, sc = model.frame_data(k)
        out.append(detections(lik.matched_filter(d_pad, bh, bv, sc), lik.half, pfa))
    return out


def detection_probability(lik: FrameLikelihood, scene: FramesConfig, pfa: float) -> float:
    """The matched filter's mean detection probability over the aspects at the target's own interior position
    and aspect: Phi(sqrt(rho_a) / sigma_c - Phi^-1(1 - pfa)), rho_a = h_a^T A h_a (the GMRF's known beta)."""
    i, j = lik.rho0.shape[1] // 2, lik.rho0.shape[2] // 2
    rho = lik.rho0[:, i, j] - 2.0 * (scene.beta_h * lik.rhoh[:, i, j] + scene.beta_v * lik.rhov[:, i, j])
    return float(ndtr(np.sqrt(rho) / scene.sigma_c - ndtri(1.0 - pfa)).mean())


def frame_sensor(scene: FramesConfig, cfg: ChainConfig, pd: float) -> Sensor:
    """The position sensor of a frame (module docstring): centred, covering the extended grid, a scan per
    frame interval, ``measurement_sd`` pixels."""
    h = scene.template_half
    reach = math.hypot((scene.rows - 1) / 2 + h, (scene.cols - 1) / 2 + h) + 1.0
    return Sensor(name="frame", kind="position", x_m=(scene.rows - 1) / 2, y_m=(scene.cols - 1) / 2,
                  scan_period_s=scene.dt, sigma_position_m=cfg.measurement_sd, min_range_m=0.0,
                  max_range_m=reach, pd=pd, clutter=Clutter(law="none"))


def track_filter(scene: FramesConfig, cfg: ChainConfig) -> IMM:
    """The per-track filter: one CV model with sigma_q = sqrt(q / dt), position fixes of ``measurement_sd``."""
    var = cfg.measurement_sd**2
    return IMM(models=(ConstantVelocity(sigma_q=math.sqrt(scene.q / scene.dt)),), tpm=((1.0,),), mu0=(1.0,),
               measurement=PositionMeasurement(((var, 0.0), (0.0, var))))


def tracker_params(name: str, scene: FramesConfig, cfg: ChainConfig, n_aspects: int, pfa: float, pd: float
                   ) -> dict[str, Any]:
    """Tracker ``name``'s params from the frame model and the detector (module docstring), then ``cfg.params``."""
    v_max = cfg.speed_sds * scene.birth_velocity_sd
    start_sd = math.sqrt(2.0) * cfg.measurement_sd / scene.dt
    pd = min(max(pd, PD_FLOOR), PD_CEILING)
    lifecycle = {**THESIS_LIFECYCLE, "v_min": 0.0, "v_max": v_max, "max_speed_m_s": v_max + cfg.speed_sds * start_sd,
                 "max_position_sd_m": None, "m": CONFIRM_M, "n": CONFIRM_N,
                 "max_misses": math.ceil(math.log(COAST_RISK) / math.log1p(-pd) - 1e-9)}  # not 2 for 1 + ulp
    params: dict[str, Any] = {}
    if name == "mht":
        params |= {"clutter_density": n_aspects * pfa, "pd": pd}
    override = dict(cfg.params.get(name, {}))
    lifecycle |= override.pop("lifecycle", {})
    return params | override | {"lifecycle": lifecycle}


def run_chain(model: TBDModel, hits: list[np.ndarray], name: str, cfg: ChainConfig, pfa: float) -> ChainResult:
    """Track each run's ``hits`` (`frame_detections` of ``model`` at ``pfa``) with tracker ``name``; one tracker,
    reset per run, on one BLAS thread (as `nnda.study.track.run_tracker`)."""
    scene, lik = model.model, model.likelihood
    pd = detection_probability(lik, scene, pfa)
    sensor = frame_sensor(scene, cfg, pd)
    params = tracker_params(name, scene, cfg, lik.n_aspects, pfa, pd)
    cls = TRACKERS[name]
    config = validated(cls.config_type, params, f"tbd chain {name}", f"{name} config")
    track = track_filter(scene, cfg)
    R, K = model.runs, model.steps
    present = np.zeros((R, K), bool)
    position = np.full((R, K, 2), np.nan)
    tracks = np.zeros((R, K), np.int64)
    by_run = [np.split(h[:, 1:3], np.searchsorted(h[:, 0], np.arange(1, R))) for h in hits]  # hits sorted by run
    seconds = 0.0
    with threadpool_limits(1):
        tracker = cls((sensor,), config, track_filter=track)
        for r in range(R):
            tracker.reset()
            used: dict[int, int] = {}
            for k in range(K):
                t0 = time.perf_counter()
                out = tracker.step(Scan(k + 1, (k + 1) * scene.dt, np.ascontiguousarray(by_run[k][r]), 0))
                seconds += time.perf_counter() - t0
                for tid, c in zip(out.track_id.tolist(), out.contact.tolist()):
                    used[tid] = used.get(tid, 0) + (c != NO_CONTACT)
                confirmed = np.flatnonzero(out.status == CONFIRMED)
                tracks[r, k] = confirmed.size
                if confirmed.size:
                    best = max(confirmed.tolist(), key=lambda i: (used[int(out.track_id[i])], -out.track_id[i]))
                    present[r, k], position[r, k] = True, out.state[best, [0, 2]]
    settings = {"params": params, "sigma_q": track.models[0].sigma_q, "measurement_sd": cfg.measurement_sd,
                "detection_probability": pd}
    return ChainResult(present, position, tracks, seconds, settings)

