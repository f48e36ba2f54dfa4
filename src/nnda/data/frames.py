"""Image frames after Bruno, Araújo & Pavlov: one dim target of changing aspect in GMRF clutter.

R runs of K frames of L x M pixels at once, saved as their own files (not
detection rows):

    cfg = FramesConfig(ptcr_db=6.5)                    # 128 x 128, 20 frames, the named defaults below
    fs = simulate(cfg, runs=100, seed=0)               # fs.frames (R, K, L, M), fs.truth (R, K, 5)
    fs.templates                                       # (A, h, w) the A aspects' signatures at the PTCR amplitude
    write_frames(fs, "frames/a")                       # manifest.json + frames.npy, truth.npy, ... atomically
    fs = read_frames("frames/a")                       # arrays memory-mapped (read lazily), digests checked
    T = aspect_transition(G, p_entry, p_in)            # (..., A+1, A+1) eq. (1), T[i, j] = P(z_n = i | z_n-1 = j)

Pixels: x is the row and y the column (the paper's eq. 10), both in pixels
(xi = 1) with pixel centres at integers 0..L-1 and 0..M-1; the quantised
centroid is s* = (round(x), round(y)). A template's support is the square of
offsets -h..h (``template_half`` h); a centroid is on the extended grid when
at least one template pixel is in the frame: -h <= s* <= L-1+h (rows), and
likewise for columns. The truth row of a frame is [x, vx, y, vy, z] with z
the aspect (0 = absent, i = template i >= 1).

Truth: frame 1's target is born (f_0, below) with a uniformly drawn aspect.
From frame n-1 to n the state moves by nearly-constant velocity per axis,
s_n = F s_n-1 + u_n with F = [[1, dt], [0, 1]] and E[u u^T] = q [[dt^3/3,
dt^2/2], [dt^2/2, dt]] (the paper's dt = 0.04, q = 6); a present target whose
new centroid has left the extended grid becomes absent, otherwise its aspect
moves by G; an absent target enters with probability p_entry (eq. 1), born
again from f_0. (This draws s first and then z, where the paper's samplers draw z
first; the marginal P(z_n) of eq. 1 is the same.) Frames are Y = B + H(s*,
z) + V: B an optional piecewise-constant background of local means, H the
template clipped at the borders, V GMRF clutter (`nnda.data.gmrf`). The
amplitude is set by the peak target-to-clutter ratio PTCR = 20 log10(max a
/ sigma_c) dB (sigma_c the innovation std).

What the paper leaves out, chosen here (named constants):

- frame size `DEFAULT_SHAPE`; GMRF `DEFAULT_BETA` (beta_h, beta_v), a
  moderately correlated field of our choosing; sigma_c 1;
- the reference target (`reference_target`: a vehicle seen from above, a
  hull of level `HULL_LEVEL`, a turret of level 1 and a gun of level
  `GUN_LEVEL`) and its `DEFAULT_ASPECTS` (identity, a rotation, a scale, a
  shear), each rasterised on a 7 x 7 support with `SUPERSAMPLE`^2 samples
  per pixel and scaled to peak 1;
- G: stay with probability `ASPECT_STAY`, else move to any other aspect
  alike; p_entry `P_ENTRY`;
- the birth f_0: the centroid uniform over the positions with the whole
  template in the frame, each velocity N(0, `BIRTH_VELOCITY_SD`^2) (pixels
  per time unit).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from nnda.data.gmrf import check_gmrf
from nnda.data.gmrf import sample as sample_gmrf
from nnda.data.reentry import transition_matrices, white_noise_acceleration
from nnda.errors import DatasetError
from nnda.files import atomic_directory, file_digests, listed_file, read_json, verify_digests, write_json

FORMAT = "nnda-frames"
FORMAT_VERSION = 1
MANIFEST = "manifest.json"
#: the data files of a frame set: frames (R, K, L, M), truth (R, K, 5), templates (A, h, w), background (L, M)
FILES = {"frames": "frames.npy", "truth": "truth.npy", "templates": "templates.npy", "background": "background.npy"}

DEFAULT_SHAPE = (128, 128)
#: (beta_h, beta_v): our choice, not the paper's (marginal pixel variance 5.31 for sigma_c^2 = 4)
DEFAULT_BETA = (0.22, 0.2)
#: a template's support is offsets -3..3 in rows and columns (7 x 7)
TEMPLATE_HALF = 3
#: samples per pixel side when a template is rasterised
SUPERSAMPLE = 4
HULL_LEVEL = 0.6
GUN_LEVEL = 0.8
ASPECT_STAY = 0.8
P_ENTRY = 0.1
#: the paper's frame interval (time units) and acceleration-noise intensity (pixels^2 per time unit^3)
DT = 0.04
Q = 6.0
BIRTH_VELOCITY_SD = 5.0
#: truth columns
TRUTH_COLUMNS = ("x", "vx", "y", "vy", "z")

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Aspect(BaseModel):
    """An affine variant of the reference target: rotated by ``rotation_deg`` (counter-clockwise in the
    row-column plane), scaled by ``scale`` and sheared by ``shear`` (column += shear x row), in that order
    read right to left: p = Rot Scale Shear u."""

    model_config = _STRICT

    rotation_deg: float = 0.0
    scale: float = Field(1.0, gt=0)
    shear: float = 0.0


DEFAULT_ASPECTS = (Aspect(), Aspect(rotation_deg=35.0), Aspect(scale=0.8), Aspect(shear=0.4))


class FramesConfig(BaseModel):
    """Frames of one target (module docstring): ``rows`` L x ``cols`` M pixels, ``frames`` K per run, the
    GMRF ``beta_h``, ``beta_v``, ``sigma_c``, ``ptcr_db``, the ``aspects``, ``template_half``, G's
    ``aspect_stay``, ``p_entry``, motion ``dt`` and ``q``, ``birth_velocity_sd``, and the background:
    ``background_blocks`` b (0: none; else a b x b grid of constant local means) of std ``background_sd``;
    the ``scenario``: "random" (the model's own life cycle) or "exit-reentry" (`simulate_truth`) with its
    ``exit_speed`` (pixels per time unit), ``exit_frames`` and ``reentry_frame`` (1-based)."""

    model_config = _STRICT

    rows: int = Field(DEFAULT_SHAPE[0], ge=3)
    cols: int = Field(DEFAULT_SHAPE[1], ge=3)
    frames: int = Field(20, ge=1)
    beta_h: float = DEFAULT_BETA[0]
    beta_v: float = DEFAULT_BETA[1]
    sigma_c: float = Field(1.0, gt=0)
    ptcr_db: float = 8.1
    aspects: tuple[Aspect, ...] = Field(DEFAULT_ASPECTS, min_length=1)
    template_half: int = Field(TEMPLATE_HALF, ge=0)
    aspect_stay: float = Field(ASPECT_STAY, ge=0, le=1)
    p_entry: float = Field(P_ENTRY, ge=0, le=1)
    dt: float = Field(DT, gt=0)
    q: float = Field(Q, ge=0)
    birth_velocity_sd: float = Field(BIRTH_VELOCITY_SD, ge=0)
    background_blocks: int = Field(0, ge=0)
    background_sd: float = Field(2.0, ge=0)
    scenario: Literal["random", "exit-reentry"] = "random"
    exit_speed: float = Field(15.0, gt=0)
    exit_frames: int = Field(15, ge=1)
    reentry_frame: int = Field(30, ge=2)

    @model_validator(mode="after")
    def _check(self) -> FramesConfig:
        side = 2 * self.template_half + 1
        if side > min(self.rows, self.cols):
            raise ValueError(f"template_half: the template ({side} x {side}) is larger than the frame "
                             f"({self.rows} x {self.cols})")
        check_gmrf(self.beta_h, self.beta_v, self.sigma_c, self.shape, where="beta_h, beta_v")
        return self

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows, self.cols)

    @property
    def amplitude(self) -> float:
        """The templates' peak value: sigma_c 10^(PTCR / 20)."""
        return self.sigma_c * 10.0 ** (self.ptcr_db / 20.0)


#: bytes per pixel of every frame of a run that drawing and filtering it hold (the float64 frames, the copy less
#: the background, the clutter draw's temporaries: measured 17 B on 50 frames)
PIXEL_BYTES = 20
#: bytes per pixel of one frame of a run that filtering holds while it works on that frame (the whitened and
#: padded frame, the clutter estimate's neighbour sums)
FRAME_WORK_BYTES = 64


def frames_bytes(cfg: FramesConfig, runs: int) -> int:
    """Bytes that drawing ``runs`` runs of ``cfg`` (`simulate`) and filtering them need: `PIXEL_BYTES` per pixel
    of each of their frames and `FRAME_WORK_BYTES` per pixel of the frame being filtered. Arithmetic on the
    config, for a caller to refuse a size before anything is allocated."""
    return runs * cfg.rows * cfg.cols * (cfg.frames * PIXEL_BYTES + FRAME_WORK_BYTES)


@dataclass(frozen=True)
class FrameSet:
    """R runs of K frames: ``frames`` (R, K, L, M), ``truth`` (R, K, 5) [x, vx, y, vy, z], ``templates``
    (A, h, w) at the amplitude, ``background`` (L, M), the ``config`` and the ``seed``."""

    frames: np.ndarray
    truth: np.ndarray
    templates: np.ndarray
    background: np.ndarray
    config: FramesConfig
    seed: int

    @property
    def runs(self) -> int:
        return self.frames.shape[0]

    @property
    def steps(self) -> int:
        return self.frames.shape[1]


def reference_target(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The reference signature at points (u rows, v columns) in pixels from its centroid, peak 1: a hull
    |u| <= 2.8, |v| <= 2.2 of level HULL_LEVEL, a turret of radius 1.3 (level 1) and a gun along -u."""
    out = np.where((np.abs(u) <= 2.8) & (np.abs(v) <= 2.2), HULL_LEVEL, 0.0)
    out = np.where((u >= -3.4) & (u <= -1.0) & (np.abs(v) <= 0.35), GUN_LEVEL, out)
    return np.where(u**2 + v**2 <= 1.3**2, 1.0, out)


def template_library(aspects: tuple[Aspect, ...] = DEFAULT_ASPECTS, half: int = TEMPLATE_HALF) -> np.ndarray:
    """(A, 2 half + 1, 2 half + 1) the aspects' signatures, each the mean of the reference at SUPERSAMPLE^2
    points per pixel mapped back through the aspect's affine map, scaled to peak 1."""
    side = 2 * half + 1
    sub = (np.arange(SUPERSAMPLE) + 0.5) / SUPERSAMPLE - 0.5
    grid = np.arange(-half, half + 1)
    pu = (grid[:, None] + sub[None, :]).ravel()
    P = np.stack(np.meshgrid(pu, pu, indexing="ij")).reshape(2, -1)  # (2, side^2 S^2) row, column
    out = np.empty((len(aspects), side, side))
    for i, a in enumerate(aspects):
        t = np.deg2rad(a.rotation_deg)
        rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
        shear = np.array([[1.0, 0.0], [a.shear, 1.0]])
        u = np.linalg.solve(rot @ (a.scale * shear), P)
        img = reference_target(u[0], u[1]).reshape(side, SUPERSAMPLE, side, SUPERSAMPLE).mean(axis=(1, 3))
        if img.max() <= 0:
            raise DatasetError(f"aspect {i + 1} ({a}): the target falls outside the {side} x {side} support")
        out[i] = img / img.max()
    return out


def aspect_matrix(n_aspects: int, stay: float = ASPECT_STAY) -> np.ndarray:
    """G (A, A), G[i, j] = P(aspect i | aspect j): ``stay`` on the diagonal, the rest spread alike over the
    other aspects (columns sum to one)."""
    if n_aspects == 1:
        return np.ones((1, 1))
    G = np.full((n_aspects, n_aspects), (1.0 - stay) / (n_aspects - 1))
    np.fill_diagonal(G, stay)
    return G


def aspect_transition(G: np.ndarray, p_entry: float, p_in: np.ndarray | float) -> np.ndarray:
    """Eq. (1): T (..., A+1, A+1) with T[..., i, j] = P(z_n = i | z_n-1 = j, s_n-1), for P_in = ``p_in``
    (...,) the probability that the predicted centroid is on the extended grid: G(i, j) P_in (i, j >= 1),
    1 - P_in (i = 0, j >= 1), p_entry / A (i >= 1, j = 0), 1 - p_entry (i = j = 0)."""
    A = G.shape[0]
    p_in = np.asarray(p_in, dtype=float)[..., None, None]
    T = np.zeros(p_in.shape[:-2] + (A + 1, A + 1))
    T[..., 1:, 1:] = G * p_in
    T[..., 0, 1:] = 1.0 - p_in[..., 0]
    T[..., 1:, 0] = p_entry / A
    T[..., 0, 0] = 1.0 - p_entry
    return T


def on_extended_grid(x: np.ndarray, y: np.ndarray, shape: tuple[int, int], half: int) -> np.ndarray:
    """Whether centroids (x rows, y columns) quantise onto the extended grid of an L x M frame."""
    r, c = np.rint(x), np.rint(y)
    return (r >= -half) & (r <= shape[0] - 1 + half) & (c >= -half) & (c <= shape[1] - 1 + half)


def ncv_matrices(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """F (4, 4) and the lower Cholesky factor of Q (4, 4) of the NCV motion in [x, vx, y, vy]."""
    F = transition_matrices(dt)[0]
    Qm = white_noise_acceleration(dt, q)
    return F, np.linalg.cholesky(Qm) if q > 0 else np.zeros((4, 4))


def sample_birth(cfg: FramesConfig, rng: np.random.Generator, size: tuple[int, ...]) -> np.ndarray:
    """States (*size, 4) from f_0: centroid uniform over [h, L-1-h] x [h, M-1-h], velocities N(0, sd^2)."""
    h = cfg.template_half
    s = np.empty((*size, 4))
    s[..., 0] = rng.uniform(h, cfg.rows - 1 - h, size)
    s[..., 2] = rng.uniform(h, cfg.cols - 1 - h, size)
    s[..., 1::2] = cfg.birth_velocity_sd * rng.standard_normal((*size, 2))
    return s


def simulate_truth(cfg: FramesConfig, rng: np.random.Generator) -> np.ndarray:
    """One run's truth (K, 5) [x, vx, y, vy, z] (module docstring). The "exit-reentry" scenario (the paper's
    50-frame demonstration) starts the target moving right at ``exit_speed`` from where it reaches the
    extended grid's right edge after about ``exit_frames`` frames (its row and aspect drawn as at a birth),
    keeps it absent once it has left, and brings a new target in from f_0 at ``reentry_frame``; its motion
    and aspect follow the model throughout."""
    A = len(cfg.aspects)
    G = aspect_matrix(A, cfg.aspect_stay)
    F, LQ = ncv_matrices(cfg.dt, cfg.q)
    out = np.empty((cfg.frames, 5))
    s, z = sample_birth(cfg, rng, ()), int(rng.integers(1, A + 1))
    scripted = cfg.scenario == "exit-reentry"
    if scripted:
        edge = cfg.cols - 1 + cfg.template_half + 0.5
        s[2], s[3] = edge - cfg.exit_speed * cfg.dt * cfg.exit_frames, cfg.exit_speed
    for n in range(cfg.frames):
        if n:
            s = F @ s + LQ @ rng.standard_normal(4)
            if z and not on_extended_grid(s[0], s[2], cfg.shape, cfg.template_half):
                z = 0
            elif z:
                z = int(rng.choice(A, p=G[:, z - 1])) + 1
            elif n + 1 == cfg.reentry_frame if scripted else rng.random() < cfg.p_entry:
                s, z = sample_birth(cfg, rng, ()), int(rng.integers(1, A + 1))
        out[n, :4], out[n, 4] = s, z
    return out


def place(image: np.ndarray, template: np.ndarray, r: int, c: int) -> None:
    """Add ``template`` (h, w) centred at pixel (r, c) to ``image`` (L, M), clipped at the borders."""
    hr, hc = template.shape[0] // 2, template.shape[1] // 2
    r0, r1 = max(r - hr, 0), min(r + hr + 1, image.shape[0])
    c0, c1 = max(c - hc, 0), min(c + hc + 1, image.shape[1])
    if r0 < r1 and c0 < c1:
        image[r0:r1, c0:c1] += template[r0 - r + hr:r1 - r + hr, c0 - c + hc:c1 - c + hc]


def background(cfg: FramesConfig, rng: np.random.Generator) -> np.ndarray:
    """The piecewise-constant local means (L, M): a b x b grid of blocks, each N(0, background_sd^2)."""
    b = cfg.background_blocks
    if b == 0:
        return np.zeros(cfg.shape)
    levels = cfg.background_sd * rng.standard_normal((b, b))
    rows = np.minimum(np.arange(cfg.rows) * b // cfg.rows, b - 1)
    cols = np.minimum(np.arange(cfg.cols) * b // cfg.cols, b - 1)
    return levels[rows[:, None], cols[None, :]]


def simulate(cfg: FramesConfig, runs: int, seed: int, first_run: int = 0) -> FrameSet:
    """``runs`` runs of ``cfg``; run r draws from SeedSequence([seed, first_run + r]) (a run's frames do not
    depend on how many runs are drawn with it), the background from SeedSequence([seed])."""
    if runs < 1:
        raise DatasetError(f"frames: runs must be >= 1, got {runs}")
    templates = cfg.amplitude * template_library(cfg.aspects, cfg.template_half)
    bg = background(cfg, np.random.default_rng(np.random.SeedSequence([seed])))
    frames = np.empty((runs, cfg.frames, *cfg.shape))
    truth = np.empty((runs, cfg.frames, 5))
    for r in range(runs):
        rng = np.random.default_rng(np.random.SeedSequence([seed, first_run + r]))
        truth[r] = simulate_truth(cfg, rng)
        frames[r] = bg + sample_gmrf(cfg.shape, cfg.beta_h, cfg.beta_v, cfg.sigma_c, rng, (cfg.frames,))
        for n, (x, _, y, _, z) in enumerate(truth[r]):
            if z:
                place(frames[r, n], templates[int(z) - 1], int(np.rint(x)), int(np.rint(y)))
    return FrameSet(frames, truth, templates, bg, cfg, seed)


def write_frames(fs: FrameSet, out: str | Path, overwrite: bool = False) -> Path:
    """``out``/manifest.json and the FILES, atomically (a temporary sibling renamed into place)."""
    out = Path(out)
    with atomic_directory(out, overwrite) as tmp:
        for key, name in FILES.items():
            np.save(tmp / name, np.ascontiguousarray(getattr(fs, key), dtype=np.float64))
        write_json(tmp / MANIFEST, {
            "format": FORMAT, "format_version": FORMAT_VERSION, "config": fs.config.model_dump(mode="json"),
            "seed": fs.seed, "shapes": {k: list(getattr(fs, k).shape) for k in FILES},
            "truth_columns": list(TRUTH_COLUMNS), "files": file_digests(tmp, FILES.values())})
    return out


def _listed_digests(path: Path, meta: dict) -> dict[str, str]:
    """The manifest's field 'files' (name -> SHA-256), checked before any file is opened: exactly the data files
    of a frame set (`FILES`), each a plain name resolving inside ``path`` (`nnda.files.listed_file`)."""
    where = path / MANIFEST
    recorded = meta["files"]
    if not isinstance(recorded, dict) or not all(isinstance(v, str) for v in recorded.values()):
        raise DatasetError(f"{where}: field 'files' must map each data file's name to its SHA-256, got "
                           f"{type(recorded).__name__}; regenerate the frame set")
    for name in recorded:
        listed_file(path, name, where, "data file")
    if sorted(recorded) != sorted(FILES.values()):
        raise DatasetError(f"{where}: field 'files' lists {sorted(recorded)}; a frame set holds exactly "
                           f"{sorted(FILES.values())}; regenerate the frame set")
    return recorded


def read_frames(path: str | Path) -> FrameSet:
    """The frame set at ``path``, its arrays memory-mapped read-only; DatasetError naming the file for a
    foreign or corrupt manifest, a data file whose digest, shape or dtype differs from the manifest's."""
    path = Path(path)
    meta = read_json(path / MANIFEST, FORMAT, FORMAT_VERSION)
    for field in ("config", "seed", "shapes", "files"):
        if field not in meta:
            raise DatasetError(f"{path / MANIFEST}: field {field!r} is missing")
    try:
        cfg = FramesConfig.model_validate(meta["config"])
    except ValueError as exc:
        raise DatasetError(f"{path / MANIFEST}: field 'config' is invalid ({exc})") from None
    verify_digests(path, _listed_digests(path, meta))
    arrays = {}
    for key, name in FILES.items():
        try:
            a = np.load(path / name, mmap_mode="r", allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise DatasetError(f"{path / name}: not a readable .npy array ({exc})") from None
        if a.dtype != np.float64 or list(a.shape) != list(meta["shapes"].get(key, [])):
            raise DatasetError(f"{path / name}: {a.dtype} array of shape {a.shape}; the manifest says float64 "
                               f"{tuple(meta['shapes'].get(key, []))}")
        arrays[key] = a
    if arrays["frames"].shape[2:] != cfg.shape:
        raise DatasetError(f"{path / FILES['frames']}: frames of {arrays['frames'].shape[2:]} pixels, the config "
                           f"says {cfg.shape}")
    return FrameSet(**arrays, config=cfg, seed=int(meta["seed"]))
