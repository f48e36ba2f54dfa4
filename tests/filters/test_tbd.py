"""Track-before-detect on the SMC engine (seed 003): the mixed-state model's pieces against brute force, and
the detection logic of every filter on small frames (thresholds calibrated on nnda's default template)."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data import gmrf
from nnda.data.frames import FramesConfig, aspect_transition, on_extended_grid, simulate
from nnda.errors import FilterError
from nnda.filters.tbd import FILTERS, TBDConfig, TBDModel, run_tbd, tbd_model

#: the detection tests' setting: 64 x 64 frames, 20 runs of 20 frames, 2,000 particles per run
SMALL = FramesConfig(rows=64, cols=64, frames=20, ptcr_db=8.1)
RUNS, PARTICLES = 20, 2000
#: frames before the detection rates are counted: acquisition (present) and burn-in (absent)
ACQUISITION, BURN_IN = 5, 3


@pytest.fixture(scope="module")
def present():
    return simulate(SMALL, RUNS, 5)


@pytest.fixture(scope="module")
def absent(present):
    V = gmrf.sample(SMALL.shape, SMALL.beta_h, SMALL.beta_v, SMALL.sigma_c, np.random.default_rng(9), (RUNS, 20))
    return TBDModel(V, present.templates, SMALL, TBDConfig())


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_absent_sequences_are_declared_absent(absent, name):
    """At most 5% of target-free frames after a 3-frame burn-in are declared present (measured 0.6-2.1%)."""
    out = run_tbd(absent, name, PARTICLES, 2)
    assert out.present[:, BURN_IN:].mean() <= 0.05


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_present_targets_are_declared_present_at_8_1_db(present, name):
    """At 8.1 dB at least 95% of the frames after a 5-frame acquisition are declared present by the filters
    that resample (measured 96-99%); SIS, which never resamples, degenerates and is held to 85% (92%)."""
    out = run_tbd(tbd_model(present, TBDConfig()), name, PARTICLES, 1)
    assert out.present[:, ACQUISITION:].mean() >= (0.85 if name == "sis" else 0.95)
    err = np.hypot(*(out.position - present.truth[..., [0, 2]]).transpose(2, 0, 1))
    assert np.median(err[:, ACQUISITION:]) < 2.5  # pixels


def test_estimated_gmrf_parameters_track_as_well(present):
    out = run_tbd(tbd_model(present, TBDConfig(gmrf="estimated")), "apf", PARTICLES, 1)
    assert out.present[:, ACQUISITION:].mean() >= 0.95


def test_likelihood_evaluations_per_frame(present):
    one = simulate(SMALL.model_copy(update={"frames": 3}), 2, 0)
    counts = {name: run_tbd(tbd_model(one, TBDConfig(moves=2)), name, 100, 0).evaluations_per_frame
              for name in ("apf", "rs", "sis")}
    assert counts == {"apf": 200, "rs": 300, "sis": 100}


def test_same_seed_same_bytes():
    fs = simulate(SMALL.model_copy(update={"frames": 4}), 2, 1)
    a, b = (run_tbd(tbd_model(fs, TBDConfig()), "rs", 300, 7) for _ in range(2))
    assert a.position.tobytes() == b.position.tobytes() and a.p_absent.tobytes() == b.p_absent.tobytes()


def _model(aspect_draw="consistent", **frames):
    cfg = SMALL.model_copy(update={"frames": 2, **frames})
    return tbd_model(simulate(cfg, 1, 0), TBDConfig(aspect_draw=aspect_draw))


def test_consistent_transition_keeps_present_particles_on_the_extended_grid():
    model = _model(birth_velocity_sd=400.0)
    rng = np.random.default_rng(0)
    x = model.sample_initial(20000, rng)
    x = model.sample_transition(1, x, rng)
    present = x[..., 4] > 0
    assert on_extended_grid(x[..., 0], x[..., 2], SMALL.shape, 3)[present].all()
    assert np.isfinite(model.transition_log_density(1, x, model.sample_transition(2, x, rng))).all()


def test_paper_transition_draws_the_aspect_from_eq1():
    """Particles of aspect 2 on the border moving out: the share of each new aspect is eq. (1)'s column for
    their P_in."""
    model = _model("paper")
    n = 200_000
    x = np.zeros((1, n, 5))
    x[..., 0], x[..., 1], x[..., 2], x[..., 4] = 66.02, 12.0, 30.0, 2  # predicted row 66.5: the grid edge
    p_in = model._p_in(x)[0, 0]
    assert 0.2 < p_in < 0.8
    z = model.sample_transition(1, x, np.random.default_rng(1))[0, :, 4]
    share = np.bincount(z.astype(int), minlength=5) / n
    want = aspect_transition(model.G, SMALL.p_entry, p_in)[:, 2]
    np.testing.assert_allclose(share, want, atol=4 / np.sqrt(n))


def test_transition_log_density_is_minus_inf_only_where_impossible():
    model = _model()
    prev = np.zeros((1, 3, 5))
    prev[..., 0], prev[..., 2], prev[..., 4] = 30.0, 30.0, 1
    x = prev.copy()
    x[0, 1, 4] = 0  # present -> absent while still in the frame: impossible in the consistent order
    x[0, 2, 0] = 200.0  # present off the grid: impossible
    lp = model.transition_log_density(1, prev, x)[0]
    assert np.isfinite(lp[0]) and lp[1] == -np.inf and lp[2] == -np.inf
    # the same move's density is log G + log f_s: against the Gaussian by hand
    d = x[0, 0, :4] - model.F @ prev[0, 0, :4]
    Q = model.LQ @ model.LQ.T
    want = np.log(model.G[0, 0]) - 0.5 * (d @ np.linalg.solve(Q, d) + np.linalg.slogdet(2 * np.pi * Q)[1])
    assert lp[0] == pytest.approx(want, rel=1e-9)


def test_move_is_symmetric_in_kind_and_keeps_absent_aspects():
    model = _model()
    rng = np.random.default_rng(3)
    x = model.sample_initial(5000, rng)
    y = model.move(1, x, rng)
    absent = x[..., 4] == 0
    assert (y[..., 4][absent] == 0).all() and (y[..., 4][~absent] > 0).all()
    redrawn = (y[..., 4] != x[..., 4])[~absent].mean()
    assert 0.3 < redrawn < 0.45  # move_aspect 0.5 x 3/4 of the redraws land elsewhere


def test_estimate_is_the_presence_probability_and_the_conditional_mean():
    model = _model()
    rng = np.random.default_rng(4)
    x = model.sample_initial(50, rng)
    W = rng.dirichlet(np.ones(50))[None]
    est = model.estimate(W, x)
    p = x[0, :, 4] > 0
    assert est[0, 0] == pytest.approx(1 - W[0, p].sum(), rel=1e-9)
    np.testing.assert_allclose(est[0, 1:], (W[0, p] @ x[0, p, :4]) / W[0, p].sum(), rtol=1e-9)


def test_bad_frames_are_refused():
    fs = simulate(SMALL.model_copy(update={"frames": 2}), 1, 0)
    cfg = TBDConfig()
    runs = [[np.zeros((64, 64)), np.zeros((64, 63))]]
    with pytest.raises(FilterError, match=r"mixed sizes: run 0 frame 1 is \(64, 63\), run 0 frame 0 is \(64, 64\)"):
        TBDModel(runs, fs.templates, SMALL, cfg)
    with pytest.raises(FilterError, match=r"expected \(runs, frames, 64, 64\)"):
        TBDModel(np.zeros((1, 2, 32, 32)), fs.templates, SMALL, cfg)
    bad = np.array(fs.frames)
    bad[0, 1, 5, 7] = np.nan
    with pytest.raises(FilterError, match=r"frames \(run, frame, row, column\): non-finite value nan at index "
                                          r"\(0, 1, 5, 7\)"):
        TBDModel(bad, fs.templates, SMALL, cfg)
    with pytest.raises(FilterError, match="larger than the frame"):
        TBDModel(np.zeros((1, 1, 5, 5)), fs.templates, SMALL.model_copy(update={"rows": 5, "cols": 5}), cfg)
    with pytest.raises(FilterError, match="unknown TBD filter"):
        run_tbd(tbd_model(fs, cfg), "kalman", 10, 0)


def test_the_filters_own_q_drives_its_motion_and_p_in():
    """TBDConfig.q replaces the frames' q in the filter's transition (its noise and P_in), not in the frames."""
    fs = simulate(SMALL.model_copy(update={"frames": 2}), 1, 0)
    own, frames = tbd_model(fs, TBDConfig(q=150.0)), tbd_model(fs, TBDConfig())
    assert own.q == 150.0 and frames.q == SMALL.q
    np.testing.assert_allclose(own.LQ @ own.LQ.T, 25.0 * (frames.LQ @ frames.LQ.T), rtol=1e-9)
    x = np.zeros((1, 200_000, 5))
    x[..., 0], x[..., 2], x[..., 4] = 30.0, 30.0, 1
    v = own.sample_transition(1, x, np.random.default_rng(5))[0, :, 1]
    assert v.std() == pytest.approx(np.sqrt(150.0 * SMALL.dt), rel=0.01)  # the velocity step a frame
    edge = x.copy()
    edge[..., 0] = 66.47  # 0.03 px inside the extended grid's edge: the larger q spreads more of it off
    assert own._p_in(edge)[0, 0] < frames._p_in(edge)[0, 0] < 1.0
