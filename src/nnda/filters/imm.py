"""Interacting multiple model (IMM) filter for K tracks at once: Vargas Avila (2015), eqs. 4.43-4.55 and Sec. 5.6.

`IMM` holds the configuration (motion models, measurement model, transition
probability matrix, initial mode probabilities) and the steps; the estimates
of K tracks live in `IMMState` records of batched arrays, so one call runs
every track (a single track is K = 1):

    imm = IMM()                                   # the thesis's CV + CT IMM
    state = imm.initialise(z1, z2, t1, t2)        # two-point start, (K, 2) polar fixes
    pred = imm.predict(state, dt)                 # mixing + model predictions, dt (K,) s
    gate = pred.gating.measurement                # where to look: z (K, 2), S (K, 2, 2)
    d2 = imm.mahalanobis(gate, Z)                 # (K, N) against all N contacts
    ll = imm.log_likelihood(pred, Z)              # (K, N) for MHT scores
    state = imm.update(pred, z, mask)             # z (K, 2), mask (K,) detected or not
    x, P = imm.estimate(state)                    # combined [x, vx, y, vy] output

Models of different sizes share one padded layout: model j's state fills the
first ``models[j].dim`` entries of n = max(dim), the rest (and the matching
rows and columns of its covariance) stay exactly zero. For mixing, a smaller
model is extended by those zero entries with variance ``augment_variance``
(default: CV gets omega = 0 with variance 0; P_omega = 0.0076 is the
alternative; the thesis does not say how its 4-D and 5-D states mix); mixing
into a smaller model drops the extra rows and columns. The combined output covers the dimensions all models
share ([x, vx, y, vy] for CV + CT).

The cycle's steps (mixing and prediction, measurement prediction, update,
estimate, gate distances, mixture log-likelihoods) run as compiled loops over tracks and models
(`nnda.filters.imm_kernels`, numba), so the IMM takes the models those loops
know: `ConstantVelocity` (and its subclasses) and `CoordinatedTurn`, with a
`PolarMeasurement` or a `PositionMeasurement`; anything else is refused at
construction.

Missed scans: `update` with ``mask`` False returns the prediction for that
track, so the mode probabilities are the TPM-propagated ones. A tracker
that skips the update on a miss keeps the last posterior of a
missed track and, at its next contact, predicts once over the whole elapsed
time (dt = 4, 6 or 8 s); both uses are supported because ``dt`` is per track.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from nnda.errors import FilterError
from nnda.filters import imm_kernels, kalman
from nnda.filters.batch import Batch
from nnda.filters.imm_kernels import kernel_array
from nnda.filters.kalman import MeasurementPrediction
from nnda.filters.measurement import MeasurementModel, PolarMeasurement, PositionMeasurement, measurement_model
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn, MotionModel
from nnda.validation import check_array, check_covariance, check_finite, check_nonnegative

if TYPE_CHECKING:
    from nnda.data.scenario import Sensor

#: transition probability matrix, rows = from, columns = to (Vargas Avila (2015), eq. 5.61)
DEFAULT_TPM = ((0.99, 0.01), (0.10, 0.90))
#: initial mode probabilities (Vargas Avila (2015), eqs. 5.62-5.63)
DEFAULT_MU0 = (0.5, 0.5)
#: tolerance on probabilities summing to one
PROBABILITY_ATOL = 1e-9
#: added to probabilities before a division or a log: leaves every value above 1e-284 unchanged,
#: and a model with probability 0 stays finite (it mixes only with itself, its probability stays ~1e-300)
_TINY = 1e-300


@dataclass(frozen=True)
class IMMState(Batch):
    """IMM estimates of K tracks with r models (posterior, or predicted inside `IMMPrediction`).

    ``x`` (K, r, n) holds each model's state and ``P`` (K, r, n, n) its
    covariance, padded with zeros to n = the largest model size; ``mu`` (K, r)
    the mode probabilities. Build one with `IMM.initialise`, `IMM.from_cv` or
    the checked `IMM.make_state`.
    """

    x: np.ndarray
    P: np.ndarray
    mu: np.ndarray


@dataclass(frozen=True)
class Gating(Batch):
    """The combined (gating) prediction of K tracks: ``x`` (K, d), ``P`` (K, d, d), the combined estimate
    (eqs. 4.54-4.55) of the predicted model states on the shared dimensions, and ``measurement``, its
    measurement prediction (leading shape (K,): h and H at x, S = H P H^T + R)."""

    x: np.ndarray
    P: np.ndarray
    measurement: MeasurementPrediction


@dataclass(frozen=True)
class IMMPrediction(Batch):
    """One IMM prediction of K tracks.

    ``state`` holds the mixed and predicted model states and, in ``mu``, the
    predicted mode probabilities mu_j(k+1|k) (eq. 4.47); ``measurement`` the
    per-model measurement predictions (leading shape (K, r)); ``gating`` the
    combined prediction and its measurement prediction, where every tracker
    gates (`IMM.predict` computes all three in one compiled call).
    """

    state: IMMState
    measurement: MeasurementPrediction
    gating: Gating


@dataclass(frozen=True)
class IMM:
    """An IMM filter configuration and its batched steps (defaults: Vargas Avila (2015), Sec. 5.6).

    ``models`` are the motion models (CV then CT by default), ``measurement``
    the measurement model (polar, sigma 30 m and 3 mrad), ``tpm`` the
    transition probabilities p_ij = P(model j now | model i before), rows
    summing to one (eq. 5.61), ``mu0`` the initial mode probabilities
    (eqs. 5.62-5.63) and ``augment_variance`` the variance given to the
    padding entries of smaller models when mixing (default 0).
    """

    models: tuple[MotionModel, ...] = (ConstantVelocity(), CoordinatedTurn())
    measurement: MeasurementModel = PolarMeasurement()
    tpm: tuple[tuple[float, ...], ...] = DEFAULT_TPM
    mu0: tuple[float, ...] = DEFAULT_MU0
    augment_variance: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "models", tuple(self.models))
        r = len(self.models)
        if r == 0:
            raise FilterError("IMM.models: at least one motion model is needed")
        if any(m.dim < 4 for m in self.models):
            raise FilterError("IMM.models: every model state must start with [x, vx, y, vy]")
        other = [type(m).__name__ for m in self.models if not isinstance(m, ConstantVelocity | CoordinatedTurn)]
        if other:
            raise FilterError(f"IMM.models: the IMM's compiled cycle (`nnda.filters.imm_kernels`) runs "
                              f"ConstantVelocity and CoordinatedTurn models, got {', '.join(other)}")
        if not isinstance(self.measurement, PolarMeasurement | PositionMeasurement):
            raise FilterError(f"IMM.measurement: a PolarMeasurement or a PositionMeasurement, got "
                              f"{type(self.measurement).__name__}")
        tpm = check_array("IMM.tpm", self.tpm, (r, r), error=FilterError)
        mu0 = check_array("IMM.mu0", self.mu0, (r,), error=FilterError)
        check_finite("IMM.tpm", tpm, error=FilterError)
        check_finite("IMM.mu0", mu0, error=FilterError)
        if (tpm < 0).any() or not np.allclose(tpm.sum(axis=1), 1.0, rtol=0, atol=PROBABILITY_ATOL):
            raise FilterError(f"IMM.tpm: entries must be >= 0 and every row must sum to 1, got {tpm.tolist()}")
        if not (tpm.sum(axis=0) > 0).all():
            raise FilterError(f"IMM.tpm: every model must be reachable (a column is all zero): {tpm.tolist()}")
        if (mu0 < 0).any() or not np.isclose(mu0.sum(), 1.0, rtol=0, atol=PROBABILITY_ATOL):
            raise FilterError(f"IMM.mu0: entries must be >= 0 and sum to 1, got {mu0.tolist()}")
        check_nonnegative("IMM.augment_variance", self.augment_variance, error=FilterError)
        object.__setattr__(self, "tpm", tuple(map(tuple, tpm.tolist())))
        object.__setattr__(self, "mu0", tuple(mu0.tolist()))

    # ----------------------------------------------------------------- layout
    @property
    def n_models(self) -> int:
        return len(self.models)

    @cached_property
    def dim(self) -> int:
        """Padded state size n (the largest model's)."""
        return max(m.dim for m in self.models)

    @cached_property
    def output_dim(self) -> int:
        """Size of the combined output (the dimensions every model has)."""
        return min(m.dim for m in self.models)

    @cached_property
    def _tpm(self) -> np.ndarray:
        return np.array(self.tpm)

    @cached_property
    def _noise_basis(self) -> np.ndarray:
        """(4, r, n, n) every model's process-noise basis in the padded layout."""
        basis = np.zeros((4, self.n_models, self.dim, self.dim))
        for j, m in enumerate(self.models):
            basis[:, j, : m.dim, : m.dim] = m.noise_basis
        return basis

    @cached_property
    def _own(self) -> np.ndarray:
        """(r, n) 1 on each model's own state entries, 0 on its padding."""
        return (np.arange(self.dim) < np.array([m.dim for m in self.models])[:, None]).astype(float)

    @cached_property
    def _own2(self) -> np.ndarray:
        return self._own[:, :, None] * self._own[:, None, :]

    @cached_property
    def _kinds(self) -> np.ndarray:
        """(r,) each model's transition in the compiled cycle (`imm_kernels.CV`, `CT` or `CT_EXACT`)."""
        return np.array([(imm_kernels.CT_EXACT if m.form == "exact" else imm_kernels.CT)
                         if isinstance(m, CoordinatedTurn) else imm_kernels.CV
                         for m in self.models], dtype=np.int64)

    @cached_property
    def _dims(self) -> np.ndarray:
        return np.array([m.dim for m in self.models], dtype=np.int64)

    @cached_property
    def _omega_max(self) -> np.ndarray:
        """(r,) the turn-rate limit (rad/s) of each CT model (0 for CV)."""
        return np.array([getattr(m, "omega_max", 0.0) for m in self.models])

    @cached_property
    def polar(self) -> bool:
        """Whether the measurement is polar (range, azimuth): its azimuth residuals wrap, and the compiled
        kernels take this flag."""
        return isinstance(self.measurement, PolarMeasurement)

    @cached_property
    def _origin(self) -> np.ndarray:
        """(2,) the radar's position (m) for a polar measurement, else unused zeros."""
        return np.array(getattr(self.measurement, "origin", (0.0, 0.0)), dtype=float)

    @cached_property
    def _augment(self) -> np.ndarray:
        """(r, n, n) variance added on the padding diagonal of each model before mixing."""
        pad = 1.0 - self._own
        return self.augment_variance * pad[:, :, None] * np.eye(self.dim)

    # ------------------------------------------------------------- creation
    @classmethod
    def for_sensor(cls, sensor: Sensor) -> IMM:
        """The IMM every tracker runs for a sensor: the thesis's CV + CT models and TPM, the sensor's
        measurement model (`measurement_model`: its kind, noise and position).

        The training pairs of the IMM-extended features (`nnda.models.pairs`) run this same filter.
        """
        return cls(measurement=measurement_model(sensor))

    def for_measurement(self, measurement: MeasurementModel) -> IMM:
        """This IMM (motion models, TPM, mode priors) with another measurement model: one sensor's of several."""
        return replace(self, measurement=measurement)

    def initialise(
        self, z1: np.ndarray, z2: np.ndarray, t1: np.ndarray | float, t2: np.ndarray | float
    ) -> IMMState:
        """Start K tracks from their first two measurements z1, z2 (K, 2) at times t1 < t2 (s).

        Two-point CV estimate (eqs. 5.26-5.31) with the analytic covariance
        (eq. 5.54); each model extends it (CT: omega = 0, variance P_omega,
        eq. 5.56); mode probabilities ``mu0``.
        """
        z1 = check_array("z1", z1, (None, 2), error=FilterError)
        z2 = check_array("z2", z2, (z1.shape[0], 2), error=FilterError)
        self.measurement.validate("z1", z1)
        self.measurement.validate("z2", z2)
        dt = np.asarray(t2, dtype=float) - np.asarray(t1, dtype=float)
        if dt.ndim and dt.shape != (z1.shape[0],):
            raise FilterError(f"t1, t2: expected scalars or shape ({z1.shape[0]},), got interval shape {dt.shape}")
        if not np.all(np.isfinite(dt) & (dt > 0)):
            raise FilterError(f"t1, t2: the second measurement must come after the first, got t2 - t1 = {dt}")
        p1, _ = self.measurement.position(z1)
        p2, cov2 = self.measurement.position(z2)
        return self.start(p1, p2, cov2, dt)

    def start(self, p1: np.ndarray, p2: np.ndarray, cov2: np.ndarray, dt: np.ndarray | float) -> IMMState:
        """`initialise` from Cartesian fixes, unchecked: p1, p2 (K, 2) m, cov2 (K, 2, 2) the second
        fix's covariance (m^2), dt = t2 - t1 > 0 (s, scalar or (K,)).

        For callers that hold the fixes' positions already and have checked them (the trackers): one
        compiled call (`imm_kernels.start`, the arithmetic of `two_point` and `from_cv`).
        """
        p1, p2, cov2, dt = kernel_array(p1), kernel_array(p2), kernel_array(cov2), kernel_array(np.atleast_1d(dt))
        return IMMState(*imm_kernels.start(p1, p2, cov2, dt, *self.start_arrays))

    @property
    def start_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The arrays `imm_kernels.start` takes beside the fixes: what each model puts beyond the CV estimate (r,
        n), its covariance (r, n, n), and the initial mode probabilities (r,)."""
        return (*self._cv_extension, self._mu0_array)

    def from_cv(self, x: np.ndarray, P: np.ndarray, mu: np.ndarray | None = None) -> IMMState:
        """IMM state of K tracks from CV estimates x (K, 4), P (K, 4, 4); every model starts there."""
        x = check_array("x", x, (None, 4), error=FilterError)
        P = check_array("P", P, (x.shape[0], 4, 4), error=FilterError)
        check_finite("x", x, error=FilterError)
        check_covariance("P", P, error=FilterError)
        state = self._from_cv(x, P)
        return state if mu is None else IMMState(state.x, state.P, self._checked_mu(mu, len(x)))

    def make_state(self, x: np.ndarray, P: np.ndarray, mu: np.ndarray | None = None) -> IMMState:
        """A checked IMM state from padded arrays x (K, r, n), P (K, r, n, n), mu (K, r)."""
        r, n = self.n_models, self.dim
        x = check_array("x", x, (None, r, n), error=FilterError)
        P = check_array("P", P, (x.shape[0], r, n, n), error=FilterError)
        check_finite("x", x, error=FilterError)
        for j, m in enumerate(self.models):
            check_covariance(f"P[:, {j}] (model {type(m).__name__})", P[:, j, : m.dim, : m.dim], error=FilterError)
        if (x * (1.0 - self._own)).any() or (P * (1.0 - self._own2)).any():
            raise FilterError("x, P: entries beyond a model's own state size must be zero")
        mu = np.broadcast_to(self._mu0_array, (len(x), r)) if mu is None else self._checked_mu(mu, len(x))
        return IMMState(x, P, np.array(mu, dtype=float))

    @cached_property
    def _mu0_array(self) -> np.ndarray:
        return np.array(self.mu0)

    def _checked_mu(self, mu: np.ndarray, K: int) -> np.ndarray:
        mu = check_array("mu", mu, (K, self.n_models), error=FilterError)
        check_finite("mu", mu, error=FilterError)
        if (mu < 0).any() or not np.allclose(mu.sum(axis=1), 1.0, rtol=0, atol=PROBABILITY_ATOL):
            raise FilterError("mu: mode probabilities must be >= 0 and sum to 1 per track")
        return mu

    def _from_cv(self, x: np.ndarray, P: np.ndarray) -> IMMState:
        K, r, n = len(x), self.n_models, self.dim
        xs = np.empty((K, r, n))
        xs[:] = self._cv_extension[0]
        xs[:, :, :4] = x[:, None]
        Ps = np.empty((K, r, n, n))
        Ps[:] = self._cv_extension[1]
        Ps[:, :, :4, :4] = P[:, None]
        return IMMState(xs, Ps, np.repeat(self._mu0_array[None, :], K, axis=0))

    @cached_property
    def _cv_extension(self) -> tuple[np.ndarray, np.ndarray]:
        """(r, n), (r, n, n): what each model's ``from_cv`` puts beyond the CV part, in the padded layout (CT:
        omega 0 with variance P_omega). For CV and CT ``from_cv`` keeps the CV estimate and appends
        constants, so a start is these with the CV estimate written over the first four entries."""
        xs, Ps = np.zeros((self.n_models, self.dim)), np.zeros((self.n_models, self.dim, self.dim))
        for j, m in enumerate(self.models):
            xs[j, :m.dim], Ps[j, :m.dim, :m.dim] = (a[0] for a in m.from_cv(np.zeros((1, 4)), np.zeros((1, 4, 4))))
        return xs, Ps

    # ----------------------------------------------------------------- steps
    def predict(self, state: IMMState, dt: np.ndarray | float, *, check: bool = True) -> IMMPrediction:
        """Mix (eqs. 4.46-4.49) and predict every model over ``dt`` (s, scalar or (K,)).

        Also predicts each model's measurement and innovation covariance.
        ``check=False`` skips the input checks (for callers whose states and
        intervals are known to be valid, such as the trackers' scan loop).
        """
        dt = np.asarray(dt, dtype=float)
        if check:
            self._check_predict(state, dt)
        if not dt.ndim:
            dt = np.full(len(state), float(dt))
        xp, Pp, mu_pred, *out = imm_kernels.predict(
            state.x, state.P, state.mu, dt, self._tpm, self._kinds, self._dims, self._omega_max, self._noise_basis,
            self._augment, self.polar, self._origin, self.measurement.R, self.output_dim)
        xc, Pc = out[7:9]
        return IMMPrediction(IMMState(xp, Pp, mu_pred), _measured(xp.shape[:-1], *out[:7]),
                             Gating(xc, Pc, _measured(xc.shape[:-1], *out[9:])))

    def _check_predict(self, state: IMMState, dt: np.ndarray) -> None:
        K = len(state)
        if state.x.shape[1:] != (self.n_models, self.dim):
            raise FilterError(
                f"state: expected x of shape (K, {self.n_models}, {self.dim}) for this IMM, got {state.x.shape}"
            )
        if dt.ndim and dt.shape != (K,):
            raise FilterError(f"dt: expected a scalar or shape ({K},), got {dt.shape}")
        if K and not (dt.min() >= 0 and np.isfinite(dt.max())):
            raise FilterError(f"dt: intervals must be finite and >= 0 s, got {dt}")

    def update(self, pred: IMMPrediction, z: np.ndarray, mask: np.ndarray | None = None, *,
               check: bool = True, rows: np.ndarray | None = None) -> IMMState:
        """Update every model with its track's measurement and the mode probabilities (eqs. 4.50-4.53).

        ``z`` (K, 2) holds one measurement per track; ``mask`` (K,) bool says
        which tracks have one (default: all). A track without one keeps its
        prediction, including the TPM-propagated mode probabilities; its row
        of ``z`` is ignored (it may be NaN). ``check=False`` skips the input
        checks (for callers whose measurements are known to be valid).
        ``rows`` (K,) int, when given, names the predicted tracks to update,
        in that order and each as often as it comes (a branching tracker's
        children, one per candidate measurement): the update of
        ``pred.take(rows)``, without copying the parts it does not read.
        """
        mp, st = pred.measurement, pred.state
        x, P, mu, z_pred, S_inv, log_det, PHt = st.x, st.P, st.mu, mp.z, mp.S_inv, mp.log_det_S, mp.PHt
        if rows is not None:
            x, P, mu, z_pred, S_inv, log_det, PHt = (a[rows] for a in (x, P, mu, z_pred, S_inv, log_det, PHt))
        K = len(x)  # the array's own length: `Batch.__len__` walks the nested records, every scan
        if check:
            z = check_array("z", z, (K, 2), error=FilterError)
            if mask is not None:
                mask = np.asarray(mask)
                if mask.dtype != bool or mask.shape != (K,):
                    raise FilterError(f"mask: expected a boolean array of shape ({K},), got {mask.dtype} "
                                      f"{mask.shape}")
        if mask is None:
            mask = np.ones(K, bool)
        elif check:
            z = np.where(mask[:, None], z, z_pred[:, 0])  # rows without a measurement are ignored, NaN or not
        if check:
            self.measurement.validate("z", z)
        x, P, mu = imm_kernels.update(x, P, mu, kernel_array(z), mask, z_pred, S_inv, log_det, PHt, self.polar)
        return IMMState(x, P, mu)

    def update_position(self, pred: IMMPrediction, xy: np.ndarray, R: np.ndarray) -> IMMState:
        """Update every model of K tracks with a Cartesian position fix xy (K, 2) m of covariance R (K, 2, 2)
        m^2, whatever this IMM's own measurement model: the converted-measurement Kalman update (linear in
        the position, so valid however large the prediction's spread), mode probabilities from the fixes'
        likelihoods. Unchecked (for the trackers, whose fixes are converted checked contacts).
        """
        st = pred.state
        K, r, n = st.x.shape
        H = np.zeros((K, r, 2, n))
        H[..., 0, 0] = H[..., 1, 2] = 1.0
        PHt = np.ascontiguousarray(st.P[..., :, 0:3:2])  # P H^T, (K, r, n, 2)
        S = PHt[..., 0:3:2, :] + R[:, None]
        mp = kalman.measurement_prediction(st.x[..., 0:3:2].copy(), S, H, PHt)
        nu = xy[:, None, :] - mp.z
        x, P = kalman.correct(st.x, st.P, nu, mp)
        log_post = np.log(st.mu + _TINY) + kalman.gaussian_log_likelihood(
            kalman.mahalanobis_2x2(nu, mp.S_inv), mp.log_det_S)
        mu = np.exp(log_post - log_post.max(axis=1, keepdims=True))
        return IMMState(x * self._own, P * self._own2, mu / mu.sum(axis=1, keepdims=True))

    # -------------------------------------------------------------- outputs
    def estimate(self, state: IMMState) -> tuple[np.ndarray, np.ndarray]:
        """Combined estimate (eqs. 4.54-4.55) on the shared dimensions: x (K, d), P (K, d, d).

        For CV + CT, d = 4 ([x, vx, y, vy]). Works on a posterior
        or on ``pred.state`` (the combined prediction).
        """
        return imm_kernels.estimate(state.x, state.P, state.mu, self.output_dim)

    def combined_measurement(self, pred: IMMPrediction) -> MeasurementPrediction:
        """Predicted measurement and innovation covariance of the combined predicted state (K leading).

        This is the IMM's gating prediction: h and H evaluated at
        the combined prediction x (eq. 4.54 on the shared dimensions) with
        S = H P H^T + R; `predict` computed it (``pred.gating.measurement``).
        """
        return pred.gating.measurement

    def measurement_prediction(self, x: np.ndarray, P: np.ndarray) -> MeasurementPrediction:
        """Predicted measurements, Jacobians and innovation covariances of states x (..., n), P (..., n, n)
        (leading shape kept): `kalman.predict_measurement` for this IMM's measurement model, compiled.

        Raises FilterError if an innovation covariance is not positive definite.
        """
        n = x.shape[-1]
        return _measured(x.shape[:-1], *imm_kernels.measure(x.reshape(-1, n), P.reshape(-1, n, n), self.polar,
                                                            self._origin, self.measurement.R))

    def mahalanobis(self, mp: MeasurementPrediction, Z: np.ndarray, *, check: bool = True) -> np.ndarray:
        """Squared Mahalanobis distances (*B, N) of N measurements Z (N, 2) from each prediction in ``mp``.

        ``mp`` has leading shape B: (K,) from `combined_measurement`, or (K, r)
        for ``pred.measurement`` (one distance per model). ``check=False`` skips the check of Z (as
        `pair_log_likelihood`'s).
        """
        Z = self._checked_contacts(Z) if check else Z
        lead = mp.z.shape[:-1]
        d2 = imm_kernels.mahalanobis(mp.z.reshape(-1, 2), mp.S_inv.reshape(-1, 2, 2), Z, self.polar)
        return d2.reshape(*lead, len(Z))

    def gated_pairs(self, mp: MeasurementPrediction, Z: np.ndarray, threshold: float | np.ndarray,
                    rows: np.ndarray, *, check: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The (prediction, measurement) pairs within ``threshold`` (one for all, or (R,): each row's) of
        `mahalanobis`' squared distance, among the predictions ``rows`` (R,) of ``mp`` (leading shape (K,))
        and N measurements Z (N, 2): their row of ``mp``, measurement index and d², (P,) each, by ``rows``
        then Z (compiled: no (R, N) matrix is made). ``check`` as for `mahalanobis`."""
        Z = self._checked_contacts(Z) if check else Z
        return imm_kernels.gated_pairs(mp.z, mp.S_inv, np.asarray(rows, np.int64), Z,
                                       np.asarray(threshold, np.float64).reshape(-1), self.polar)

    def log_likelihood(self, pred: IMMPrediction, Z: np.ndarray) -> np.ndarray:
        """log p(z | track) (K, N) of N measurements Z (N, 2) under each track's IMM prediction.

        The IMM mixture likelihood log sum_j mu_j(k+1|k) N(z; z_j, S_j)
        (eqs. 4.50 and 4.53, summed over models), for MHT track scores:
        `pair_log_likelihood` of every (track, measurement) pair.
        """
        Z = self._checked_contacts(Z)
        K, N = len(pred.state), len(Z)
        return self._pairs(pred, np.repeat(np.arange(K), N), np.tile(Z, (K, 1))).reshape(K, N)

    def pair_log_likelihood(self, pred: IMMPrediction, rows: np.ndarray, Z: np.ndarray, *,
                            check: bool = True) -> np.ndarray:
        """`log_likelihood` for P (track, measurement) pairs only: track ``rows`` (P,), Z (P, 2).

        Returns (P,); the sparse form gating uses when K x N is large (compiled:
        `imm_kernels.pair_log_likelihood`). ``check=False`` skips the check of Z (for callers whose
        contacts are checked already, such as the trackers' scan loop).
        """
        return self._pairs(pred, np.asarray(rows, np.int64), self._checked_contacts(Z) if check else Z)

    def _pairs(self, pred: IMMPrediction, rows: np.ndarray, Z: np.ndarray) -> np.ndarray:
        mp = pred.measurement
        return imm_kernels.pair_log_likelihood(mp.z, mp.S_inv, mp.log_det_S, pred.state.mu, rows,
                                               np.ascontiguousarray(Z, np.float64), self.polar)

    def _checked_contacts(self, Z: np.ndarray) -> np.ndarray:
        Z = check_array("Z", Z, (None, 2), error=FilterError)
        self.measurement.validate("Z", Z)
        return kernel_array(Z)


def _measured(lead: tuple[int, ...], z: np.ndarray, S: np.ndarray, S_inv: np.ndarray, log_det: np.ndarray,
              H: np.ndarray, PHt: np.ndarray, bad: int) -> MeasurementPrediction:
    """`imm_kernels.measure`'s outputs over B = prod(lead) states (z (B, 2), S, S_inv (B, 2, 2), log_det
    (B,), H (B, 2, n), PHt (B, n, 2), the first bad index, flat), or the same shaped with ``lead`` leading
    already (`imm_kernels.predict`'s), as a `MeasurementPrediction` of leading shape ``lead``; raises
    FilterError if an innovation covariance is not positive definite."""
    if bad >= 0:
        where = tuple(int(i) for i in np.unravel_index(bad, lead))
        raise FilterError(f"innovation covariance at batch index {where} is not positive definite: "
                          f"{S.reshape(-1, 2, 2)[bad].tolist()}")
    if log_det.shape == lead:  # shaped already (a reshape is a call each, every scan)
        return MeasurementPrediction(z, S, S_inv, log_det, H, PHt)
    n = H.shape[-1]
    return MeasurementPrediction(z.reshape(*lead, 2), S.reshape(*lead, 2, 2), S_inv.reshape(*lead, 2, 2),
                                 log_det.reshape(lead), H.reshape(*lead, 2, n), PHt.reshape(*lead, n, 2))
