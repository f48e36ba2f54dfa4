"""The extended (IMM-innovation) pair features: values on hand-made tracks, the training pairs, the model file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nnda.data.generator import generate
from nnda.data.presets import PRESETS, resolve
from nnda.data.scenario import Clutter
from nnda.errors import ConfigError, ModelError
from nnda.files import with_content_digest
from nnda.filters.imm import IMM
from nnda.filters.kalman import mahalanobis_2x2
from nnda.filters.measurement import PositionMeasurement
from nnda.models.context import IMM_CONTEXT
from nnda.models.feature_sets import FEATURE_SETS, feature_set
from nnda.models.features import KINEMATIC, candidate_pairs, pair_features
from nnda.models.innovation import IMM_INNOVATION, innovation_features, scan_features
from nnda.models.mlp import MLPWeights
from nnda.models.pairs import extract_pairs, pairs_from_datasets
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, load_model, save_model
from tolerances import RTOL


@pytest.fixture(scope="module")
def predicted():
    """An IMM track started from two contacts 2 s apart, predicted 2 s ahead: (imm, prediction, gate)."""
    imm = IMM.for_sensor(PRESETS["S1"].sensor)
    z1, z2 = np.array([[20_000.0, 0.30]]), np.array([[20_150.0, 0.305]])
    pred = imm.predict(imm.initialise(z1, z2, 0.0, 2.0), 2.0)
    return imm, pred, imm.combined_measurement(pred)


def _features(imm, pred, contacts, age=10.0):
    n = len(contacts)
    return innovation_features(imm, pred, np.zeros(n, np.int64), np.asarray(contacts, float),
                               np.zeros((n, 3)), np.full(n, age))


def test_a_contact_on_the_prediction_has_zero_innovation(predicted):
    imm, pred, gate = predicted
    f = _features(imm, pred, gate.z)
    assert f.shape == (1, IMM_INNOVATION.size)
    assert np.allclose(f[0, 3:6], 0.0, atol=1e-12)  # exact zeros: the innovation is z minus itself


def test_one_sigma_in_range_reads_one(predicted):
    imm, pred, gate = predicted
    sigma_r, sigma_a = np.sqrt(gate.S[0, 0, 0]), np.sqrt(gate.S[0, 1, 1])
    contacts = gate.z + np.array([[sigma_r, 0.0], [-2 * sigma_r, 0.0], [0.0, sigma_a]])
    f = _features(imm, pred, contacts, age=7.0)
    assert np.allclose(f[:, 3], [1.0, -2.0, 0.0], atol=1e-9)
    assert np.allclose(f[:, 4], [0.0, 0.0, 1.0], atol=1e-9)
    nu = contacts - gate.z
    assert np.allclose(f[:, 5], mahalanobis_2x2(nu, gate.S_inv[[0, 0, 0]]))
    assert np.allclose(f[:, 6], np.linalg.slogdet(gate.S[0])[1])
    assert np.allclose(f[:, 7], pred.state.mu[0, 1])  # the CT model's predicted probability
    assert np.all(f[:, 8] == 7.0)


def test_azimuth_innovation_wraps_across_north(predicted):
    imm, pred, _ = predicted
    z1, z2 = np.array([[20_000.0, 2 * np.pi - 0.002]]), np.array([[20_000.0, 2 * np.pi - 0.0005]])
    pred = imm.predict(imm.initialise(z1, z2, 0.0, 2.0), 2.0)
    gate = imm.combined_measurement(pred)
    assert 0.0 < gate.z[0, 1] < 0.01  # the track is predicted just east of north ...
    just_west = np.array([[gate.z[0, 0], 2 * np.pi - 0.0005]])  # ... and the contact is just west of it
    f = _features(imm, pred, just_west)
    expected = (2 * np.pi - 0.0005 - gate.z[0, 1] - 2 * np.pi) / np.sqrt(gate.S[0, 1, 1])  # a small step, not 2 pi
    assert f[0, 4] == pytest.approx(expected) and abs(f[0, 4]) < 10


def oracle_innovation(imm, pred, track, contacts, kinematic, age):
    """One pair at a time: the IMM's combined prediction, its residual, d² by solving S x = nu."""
    gate = imm.combined_measurement(pred)
    rows = []
    for k, z, kin, a in zip(track, contacts, kinematic, age):
        nu = imm.measurement.residual(z[None], gate.z[k][None])[0]
        S = gate.S[k]
        rows.append([*kin, nu[0] / np.sqrt(S[0, 0]), nu[1] / np.sqrt(S[1, 1]), nu @ np.linalg.solve(S, nu),
                     np.log(np.linalg.det(S)), pred.state.mu[k, 1], a])
    return np.array(rows).reshape(len(track), IMM_INNOVATION.size)


@pytest.mark.parametrize("polar", [True, False])
@pytest.mark.parametrize("seed", range(4))
def test_innovation_features_against_one_pair_at_a_time(polar, seed):
    # K tracks 6-24 km out, each with its own age; pairs drawn at random over them, azimuths across north
    rng = np.random.default_rng(seed)
    imm = IMM.for_sensor(PRESETS["S1"].sensor) if polar else IMM(
        measurement=PositionMeasurement(((900.0, 50.0), (50.0, 400.0))))
    K, P = int(rng.integers(1, 12)), int(rng.integers(0, 40))
    r, b = rng.uniform(6e3, 2.4e4, K), rng.uniform(-0.3, 0.3, K) % (2 * np.pi)
    v, h = rng.uniform(50, 300, K), rng.uniform(0, 2 * np.pi, K)
    xy = lambda t: np.stack([r * np.sin(b) + v * t * np.sin(h), r * np.cos(b) + v * t * np.cos(h)], -1)  # noqa: E731
    to_z = (lambda p: np.stack([np.hypot(*p.T), np.arctan2(*p.T) % (2 * np.pi)], -1)) if polar else (lambda p: p)
    state = imm.initialise(to_z(xy(0.0)), to_z(xy(2.0)), 0.0, 2.0)
    state = imm.update(imm.predict(state, 2.0), to_z(xy(4.0) + rng.normal(0, 200.0, (K, 2))))  # mu differ
    pred = imm.predict(state, rng.choice([2.0, 4.0, 6.0], K))
    assert K == 1 or np.ptp(pred.state.mu[:, 1]) > 0
    track = rng.integers(0, K, P)
    contacts = to_z(xy(6.0)[track] + rng.normal(0, 300.0, (P, 2)))
    kinematic, age = rng.normal(0, 10, (P, 3)), rng.uniform(4, 100, P)
    got = innovation_features(imm, pred, track, contacts, kinematic, age)
    expected = oracle_innovation(imm, pred, track, contacts, kinematic, age)
    assert got.shape == (P, IMM_INNOVATION.size)
    np.testing.assert_allclose(got, expected, rtol=RTOL, atol=RTOL)  # the terms are of order one (or exact)


@pytest.mark.parametrize("seed", range(4))
def test_the_trackers_one_call_equals_candidates_then_the_features(seed):
    # K tracks with two contacts each and N contacts of a scan 2-6 s later, some of them near the tracks
    rng = np.random.default_rng(seed)
    imm = IMM.for_sensor(PRESETS["S1"].sensor)
    K, N = int(rng.integers(1, 30)), int(rng.integers(0, 120))
    p2 = rng.uniform(-15e3, 15e3, (K, 2)) + [0.0, 15e3]
    p1 = p2 - rng.uniform(-400, 400, (K, 2))
    t2 = rng.choice([2.0, 4.0, 6.0], K)
    t1, time, born = t2 - 2.0, 8.0, t2 - rng.uniform(2.0, 60.0, K)
    near = p2[rng.integers(0, K, N)] + rng.normal(0, 600.0, (N, 2))
    xy = np.where(rng.random((N, 1)) < 0.5, near, rng.uniform(-15e3, 15e3, (N, 2)) + [0.0, 15e3])
    polar = lambda p: np.stack([np.hypot(*p.T), np.arctan2(*p.T) % (2 * np.pi)], -1)  # noqa: E731
    z, az2 = polar(xy).reshape(N, 2), polar(p2)[:, 1]
    state = imm.initialise(polar(p1), polar(p2), 0.0, 2.0)
    pred = imm.predict(state, time - t2)
    gate = imm.combined_measurement(pred)
    track, cand = candidate_pairs(p2, t2, az2, xy, z[:, 1], time)
    seed_features = pair_features(p1[track], t1[track], p2[track], t2[track], xy[cand], time)
    for extended, expected in ((False, seed_features),
                               (True, innovation_features(imm, pred, track, z[cand], seed_features,
                                                          time - born[track], gate))):
        got = scan_features(imm, pred, gate if extended else None, p1, t1, p2, t2, az2, born, xy, z, time,
                            extended)
        np.testing.assert_array_equal(got[0], track)
        np.testing.assert_array_equal(got[1], cand)
        np.testing.assert_array_equal(got[2], expected)  # the same kernels: the same bits
    assert track.size > 0 or N == 0  # the draw has pairs to compare


def test_feature_sets_are_registered_and_unknown_names_refused():
    assert set(FEATURE_SETS) == {KINEMATIC.name, IMM_INNOVATION.name, IMM_CONTEXT.name}
    assert IMM_INNOVATION.names[:3] == KINEMATIC.names and IMM_INNOVATION.size == 9
    assert IMM_CONTEXT.names[:9] == IMM_INNOVATION.names and IMM_CONTEXT.size == 14
    with pytest.raises(ConfigError, match="unknown feature set 'polar-2'.*kinematic-3"):
        feature_set("polar-2")


@pytest.fixture(scope="module")
def extended_pairs():
    return pairs_from_datasets((generate(s, 0) for s in resolve("train")), features=IMM_INNOVATION.name)


def test_extended_pairs_extend_the_seed_pairs(extended_pairs, train_pairs):
    assert extended_pairs.feature_set is IMM_INNOVATION
    assert np.array_equal(extended_pairs.labels, train_pairs.labels)
    assert np.array_equal(extended_pairs.features[:, :3], train_pairs.features)  # exactly: the same call


def test_own_contacts_are_chi_square_distributed_under_the_filter(extended_pairs):
    # the filter run along each target's contacts is consistent: the own contact's d2 is chi-square(2),
    # mean 2, inside the 99 % gate 99 % of the time (the clutter's are far larger)
    own = extended_pairs.labels > 0
    d2 = extended_pairs.features[:, 5]
    assert 1.6 < d2[own].mean() < 2.4
    assert 0.975 < np.mean(d2[own] < 9.21) <= 1.0
    assert np.median(d2[~own]) > 20.0
    nu = extended_pairs.features[own][:, 3:5]
    assert np.all(np.abs(nu.mean(axis=0)) < 0.15) and np.all(np.abs(nu.std(axis=0) - 1.0) < 0.2)


def test_true_history_feeds_the_filter_true_positions():
    ds = generate(PRESETS["train03"], 0)
    measured = extract_pairs(ds, features=IMM_INNOVATION.name)
    true = extract_pairs(ds, history="true", features=IMM_INNOVATION.name)
    # gating from true positions keeps other pairs; the own contacts sit closer to a track fed the truth
    assert true.features[true.labels > 0, 5].mean() < measured.features[measured.labels > 0, 5].mean()


def test_extraction_computes_what_the_tracker_computes(tmp_path):
    """The neural tracker on a clean single-target scene scores the features of the training pairs.

    The same code on other batches (one scan's pairs against one target's): equal to rounding.
    """
    from nnda.tracking.registry import make_tracker

    scenario = PRESETS["train05"].model_copy(update={"clutter": Clutter(law="none")})
    ds = generate(scenario, 3)
    path = save_model(Scorer(MLPWeights(np.zeros((2, 9)), np.zeros(2), np.zeros(2), 0.5),
                             Normaliser(np.zeros(9), np.ones(9)), IMM_INNOVATION), tmp_path / "accept.json")
    tracker = make_tracker("nn", ds.scenario.sensor, {"model": str(path)})
    seen = []
    score = tracker.scorer

    def recording(features):
        seen.append(features.copy())
        return score(features)  # tanh(0.5) > 0: every gated pair is accepted
    tracker.scorer = recording
    for scan in ds.scans():
        tracker.step(scan)
    from_tracker = np.concatenate(seen)
    pairs = extract_pairs(ds, features=IMM_INNOVATION.name)
    own = pairs.features[pairs.labels > 0]
    assert len(from_tracker) == len(own) > 20
    np.testing.assert_allclose(from_tracker, own, rtol=1e-9, atol=1e-9)


def test_model_file_records_and_checks_the_feature_set(tmp_path):
    weights = MLPWeights(np.ones((3, 9)) * 0.1, np.zeros(3), np.ones(3), 0.0)
    scorer = Scorer(weights, Normaliser(np.zeros(9), np.ones(9)), IMM_INNOVATION)
    path = save_model(scorer, tmp_path / "ext.json")
    doc = json.loads(path.read_text())
    assert doc["feature_set"] == IMM_INNOVATION.name and doc["feature_names"] == list(IMM_INNOVATION.names)
    assert load_model(path).features is IMM_INNOVATION
    doc["feature_set"] = KINEMATIC.name  # 9 inputs cannot be the seed's 3 features
    path.write_text(json.dumps(with_content_digest(doc, "sha256")))  # as a writer of that file would have
    with pytest.raises(ModelError, match="3-9-1|9-3-1|expected 3 inputs"):
        load_model(path)
    doc["feature_set"] = "imm-innovation-12"
    path.write_text(json.dumps(with_content_digest(doc, "sha256")))
    with pytest.raises(ModelError, match="'imm-innovation-12'.*retrain"):
        load_model(path)
    with pytest.raises(ModelError, match="cannot read the 3 features"):
        Scorer(weights, Normaliser(np.zeros(9), np.ones(9)), KINEMATIC)
