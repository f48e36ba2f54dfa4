"""Track-before-detect frames (Bruno, Araújo & Pavlov): eq. (1), templates, the truth's life cycle, PTCR,
and the frame files on disk."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nnda.data import frames as fr
from nnda.errors import ConfigError, DatasetError, validated


@settings(max_examples=50, deadline=None)
@given(st.integers(1, 6), st.floats(0, 1), st.floats(0, 1), st.lists(st.floats(0, 1), min_size=1, max_size=5))
def test_eq1_probabilities_sum_to_one_for_every_state(A, stay, p_entry, p_in):
    T = fr.aspect_transition(fr.aspect_matrix(A, stay), p_entry, np.array(p_in))
    assert T.shape == (len(p_in), A + 1, A + 1) and (T >= 0).all()
    np.testing.assert_allclose(T.sum(axis=1), 1.0, rtol=1e-12)
    # absent only by leaving the extended grid
    np.testing.assert_allclose(T[:, 0, 1:], np.broadcast_to(1 - np.array(p_in)[:, None], (len(p_in), A)))
    np.testing.assert_allclose(T[:, 1:, 0], np.full((len(p_in), A), p_entry / A))


def test_templates_are_distinct_affine_variants_with_peak_one():
    t = fr.template_library()
    assert t.shape == (4, 7, 7)
    np.testing.assert_allclose(t.max(axis=(1, 2)), 1.0)
    assert all(np.abs(t[0] - t[i]).max() > 0.2 for i in range(1, 4))
    # rotating by 180 degrees flips the reference exactly
    flipped = fr.template_library((fr.Aspect(rotation_deg=180.0),))[0]
    np.testing.assert_allclose(flipped, t[0][::-1, ::-1], atol=1e-12)


def test_amplitude_from_ptcr():
    cfg = fr.FramesConfig(ptcr_db=6.5, sigma_c=2.0)
    fs = fr.simulate(cfg.model_copy(update={"frames": 2, "rows": 16, "cols": 16}), 1, 0)
    assert fs.templates.max() == pytest.approx(2.0 * 10 ** (6.5 / 20))
    assert 20 * np.log10(fs.templates.max() / 2.0) == pytest.approx(6.5)


def test_frames_are_clutter_plus_the_clipped_template():
    cfg = fr.FramesConfig(rows=20, cols=24, frames=5)
    fs = fr.simulate(cfg, 3, 7)
    assert fs.frames.shape == (3, 5, 20, 24) and fs.truth.shape == (3, 5, 5)
    clutter = fr.simulate(cfg.model_copy(update={"ptcr_db": -400.0}), 3, 7).frames
    for r in range(3):
        for n in range(5):
            x, _, y, _, z = fs.truth[r, n]
            want = np.zeros((20, 24))
            if z:
                fr.place(want, fs.templates[int(z) - 1], int(np.rint(x)), int(np.rint(y)))
            np.testing.assert_allclose(fs.frames[r, n] - clutter[r, n], want, atol=1e-12)


def test_place_clips_at_the_border():
    img = np.zeros((5, 5))
    fr.place(img, np.ones((3, 3)), 0, 4)
    assert img.sum() == 4 and img[0:2, 3:5].sum() == 4
    fr.place(img, np.ones((3, 3)), 10, 10)  # wholly outside: nothing
    assert img.sum() == 4


def test_truth_leaves_only_off_the_extended_grid_and_reenters():
    cfg = fr.FramesConfig(rows=12, cols=12, frames=200, birth_velocity_sd=80.0, p_entry=0.2, template_half=1)
    truth = np.concatenate([fr.simulate_truth(cfg, np.random.default_rng(s)) for s in range(10)])
    z = truth[:, 4]
    assert set(np.unique(z)) <= set(range(5)) and (z == 0).any() and (z > 0).any()
    present = z > 0
    assert fr.on_extended_grid(truth[present, 0], truth[present, 2], cfg.shape, 1).all()


def test_same_seed_same_bytes_and_runs_independent_of_the_batch():
    cfg = fr.FramesConfig(rows=16, cols=16, frames=3, background_blocks=2)
    a, b = fr.simulate(cfg, 3, 11), fr.simulate(cfg, 3, 11)
    assert a.frames.tobytes() == b.frames.tobytes() and a.truth.tobytes() == b.truth.tobytes()
    tail = fr.simulate(cfg, 2, 11, first_run=1)
    assert tail.frames.tobytes() == a.frames[1:].tobytes()
    assert len(np.unique(a.background)) == 4


def test_bad_configs_are_refused_naming_the_field():
    with pytest.raises(ValueError, match="larger than the frame"):
        fr.FramesConfig(rows=5, cols=40)
    with pytest.raises(ValueError, match="positive-definite region"):
        fr.FramesConfig(beta_h=0.3, beta_v=0.3)
    with pytest.raises(ConfigError, match=r"frames.toml: invalid frames.*\n  - <top level>: .*beta_h = 0.3"):
        validated(fr.FramesConfig, {"beta_h": 0.3, "beta_v": 0.3}, "frames.toml", "frames")


def test_write_and_read_back_lazily(tmp_path):
    fs = fr.simulate(fr.FramesConfig(rows=16, cols=18, frames=4), 2, 3)
    out = fr.write_frames(fs, tmp_path / "f")
    back = fr.read_frames(out)
    assert isinstance(back.frames, np.memmap)
    for key in fr.FILES:
        np.testing.assert_array_equal(getattr(back, key), getattr(fs, key))
    assert back.config == fs.config and back.seed == 3
    with pytest.raises(FileExistsError):
        fr.write_frames(fs, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]  # nothing half-written beside it


def test_corrupt_and_foreign_files_are_refused(tmp_path):
    out = fr.write_frames(fr.simulate(fr.FramesConfig(rows=10, cols=10, frames=2), 1, 0), tmp_path / "f")
    raw = bytearray((out / "frames.npy").read_bytes())
    raw[-3] ^= 0xFF
    (out / "frames.npy").write_bytes(bytes(raw))
    with pytest.raises(DatasetError, match="frames.npy: corrupt"):
        fr.read_frames(out)
    meta = json.loads((out / fr.MANIFEST).read_text())
    (out / fr.MANIFEST).write_text(json.dumps(meta | {"format": "nnda-dataset"}))
    with pytest.raises(DatasetError, match="field 'format'"):
        fr.read_frames(out)
    with pytest.raises(DatasetError, match="missing"):
        fr.read_frames(tmp_path / "nowhere")


def test_a_data_file_of_another_shape_is_refused(tmp_path):
    out = fr.write_frames(fr.simulate(fr.FramesConfig(rows=10, cols=10, frames=2), 1, 0), tmp_path / "f")
    np.save(out / "frames.npy", np.zeros((1, 2, 10, 11)))
    meta = json.loads((out / fr.MANIFEST).read_text())
    meta["files"] = fr.file_digests(out, fr.FILES.values())
    (out / fr.MANIFEST).write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="manifest says"):
        fr.read_frames(out)
