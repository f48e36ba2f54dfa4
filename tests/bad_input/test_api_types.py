"""Arguments of the wrong type through the Python API and a tracker's ``step``: each an nnda error naming the
argument (or the scan and its sensor), what was given and what is accepted; never numpy's or Python's own
TypeError or ValueError. A tracker config written for another tracker names its file and that tracker."""

from __future__ import annotations

import numpy as np
import pytest

import nnda
from nnda.data.dataset import Scan, read_dataset
from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, NndaError, TrackingError
from nnda.filters.measurement import PositionMeasurement
from nnda.study.track import run_tracker
from nnda.tracking.phd.tracker import GMPHDTracker
from nnda.tracking.registry import make_tracker

# ----------------------------------------------------------------------------- the API's arguments


@pytest.mark.parametrize("call, message", [
    (lambda ds: nnda.track(None, "gnn"),
     r"nnda\.track: argument 'dataset' is None of type NoneType; give a Dataset or a dataset directory"),
    (lambda ds: nnda.track(5, "gnn"), r"argument 'dataset' is 5 of type int; give a Dataset or a dataset directory"),
    (lambda ds: nnda.track("", "gnn"), r"argument 'dataset' is an empty string"),
    (lambda ds: nnda.track(ds, None), r"argument 'tracker' is None of type NoneType; give a registered tracker's "),
    (lambda ds: nnda.track(ds, "gnn", config=42),
     r"argument 'config' is 42 of type int; give a mapping of the tracker's options, a \.toml or \.json file"),
    (lambda ds: nnda.track(ds, "gnn", config=[("gate", 9.0)]),
     r"argument 'config' is \[\('gate', 9\.0\)\] of type list"),
    (lambda ds: nnda.track(ds, "nn", model=3.5), r"argument 'model' is 3\.5 of type float; give the nn tracker's"),
    (lambda ds: nnda.generate(None), r"nnda\.generate: argument 'scenario' is None of type NoneType; give a Scenario"),
    (lambda ds: nnda.generate(3), r"argument 'scenario' is 3 of type int; give a Scenario or a preset name"),
    (lambda ds: nnda.read_dataset(None), r"nnda\.read_dataset: argument 'path' is None of type NoneType; give a"),
    (lambda ds: nnda.read_dataset(b"ds"), r"argument 'path' is b'ds' of type bytes"),
    (lambda ds: nnda.run_study(None, "out"), r"nnda\.run_study: argument 'study' is None of type NoneType; give a"),
    (lambda ds: nnda.run_study("s.toml", 7), r"argument 'out' is 7 of type int; give the output directory"),
    (lambda ds: nnda.run_study("s.toml", "out", jobs="2"), r"argument 'jobs' is '2' of type str; give a whole number"),
    (lambda ds: nnda.run_study("s.toml", "out", jobs=True), r"argument 'jobs' is True of type bool"),
    (lambda ds: nnda.run_study("s.toml", "out", jobs=0), r"argument 'jobs' is 0; give a whole number of local"),
    (lambda ds: nnda.run_study("s.toml", "out", resume="no"), r"argument 'resume' is 'no' of type str; give True or"),
    (lambda ds: nnda.run_study("s.toml", "out", report=None), r"argument 'report' is None of type NoneType"),
    (lambda ds: nnda.run_study("s.toml", "out", dask=5), r"argument 'dask' is 5 of type int; give a Dask scheduler"),
])
def test_a_wrong_argument_type_is_named(tiny_dataset, call, message):
    with pytest.raises(ConfigError, match=message):
        call(tiny_dataset)


def test_the_api_still_tracks_as_a_study_job_does(tiny_dataset):
    ds = read_dataset(tiny_dataset)
    expected = run_tracker(ds, "gnn", {"gate": 9.0}, score=False).table
    assert nnda.track(ds, "gnn", config={"gate": 9.0}).equals(expected)
    (tiny_dataset.parent / "gnn.toml").write_text("gate = 9.0\n")
    assert nnda.track(str(tiny_dataset), "gnn", config=tiny_dataset.parent / "gnn.toml").equals(expected)


def test_a_config_file_for_another_tracker_names_the_file_and_that_tracker(tiny_dataset):
    config = tiny_dataset.parent / "mht.toml"
    config.write_text("n_scan = 3\nmax_hypotheses = 50\n")
    with pytest.raises(ConfigError) as err:
        nnda.track(tiny_dataset, "gnn", config=config)
    text = str(err.value)
    assert text.startswith(f"tracker config {config}: invalid gnn config (2 problem(s))"), text
    assert "n_scan: Extra inputs are not permitted" in text
    assert "the field(s) max_hypotheses, n_scan are options of tracker(s) mht, glmb, lmb, not of gnn" in text


def test_a_config_mapping_of_another_tracker_names_that_tracker(tiny_dataset):
    with pytest.raises(ConfigError, match=r"(?s)tracker config: invalid jpda config.*options of tracker\(s\) "
                                          r"mht(, [a-z]+)*, not of jpda"):
        make_tracker("jpda", Sensor(), {"n_scan": 2})
    with pytest.raises(ConfigError, match=r"invalid gnn config \(1 problem\(s\)\)\n  - bogus: Extra inputs") as err:
        make_tracker("gnn", Sensor(), {"bogus": 1})
    assert "options of tracker" not in str(err.value)  # no tracker has it: no guess


# ----------------------------------------------------------------------------- a tracker's step

CONTACT_TRACKERS = ("gnn", "jpda", "mht")
PHD_TRACKERS = ("gmphd", "cphd")


def _tracker(name: str):
    return make_tracker(name, Sensor())


@pytest.mark.parametrize("name", CONTACT_TRACKERS + PHD_TRACKERS)
@pytest.mark.parametrize("measurements, message", [
    (np.array([["a", "b"]]), r"scan 1 of polar sensor 'radar': measurements must be real numbers \(an integer or float "
                             r"array\), one row \[range m, azimuth rad\] per contact; got dtype <U1"),
    (np.array([[10_000.0, 1.0]], dtype=object), r"must be real numbers .* got dtype object"),
    (np.array([[True, False]]), r"must be real numbers .* got dtype bool"),
    (np.empty((0, 3)), r"scan 1 of polar sensor 'radar': measurements must have shape \(N, 2\) \[range m, azimuth "
                       r"rad\], one row per contact, got \(0, 3\)"),
    (np.ones((2, 3)), r"must have shape \(N, 2\) \[range m, azimuth rad\], one row per contact, got \(2, 3\)"),
    (np.array([10_000.0, 1.0]), r"must have shape \(N, 2\) .* got \(2,\)"),
    (np.ones((1, 2, 2)), r"must have shape \(N, 2\) .* got \(1, 2, 2\)"),
    ([[10_000.0, 1.0], [12_000.0]], r"measurements must be an \(N, 2\) array of real numbers, one row \[range m, "
                                    r"azimuth rad\] per contact \(.*inhomogeneous"),
    (np.array([[10_000.0, 1.0], [np.nan, 0.5]]), r"scan 1: contact 1 is invalid \[nan, 0\.5\] \(non-finite or "
                                                 r"non-positive range\); give finite values, with a range > 0 m"),
    (np.array([[10_000.0, np.inf]]), r"contact 0 is invalid \[10000\.0, inf\]"),
    (np.array([[-5.0, 1.0]]), r"contact 0 is invalid \[-5\.0, 1\.0\] \(non-finite or non-positive range\)"),
])
def test_bad_measurements_are_refused_by_step(name, measurements, message):
    tracker = _tracker(name)
    with pytest.raises(TrackingError, match=rf"^{name}: .*{message}"):
        tracker.step(Scan(1, 2.0, measurements))
    out = tracker.step(Scan(1, 2.0, np.empty((0, 2))))  # nothing was taken in: the same scan is still the next
    assert len(out) == 0


@pytest.mark.parametrize("name", CONTACT_TRACKERS + PHD_TRACKERS)
def test_empty_scans_and_real_numbers_of_any_width_are_taken(name):
    tracker = _tracker(name)
    for k, z in enumerate([np.empty((0, 2)), [], np.empty(0), np.array([[10_000, 1]]),
                           np.array([[10_000.0, 1.0]], dtype=np.float32)], start=1):
        tracker.step(Scan(k, 2.0 * k, z))


def test_integer_contacts_track_as_their_float_values():
    z = np.array([[10_000, 1], [12_000, 2]])
    a, b = _tracker("gnn"), _tracker("gnn")
    for k in range(1, 4):
        out_int = a.step(Scan(k, 2.0 * k, z + 10 * k))
        out_float = b.step(Scan(k, 2.0 * k, (z + 10 * k).astype(float)))
        np.testing.assert_array_equal(out_int.state, out_float.state)


@pytest.mark.parametrize("name", CONTACT_TRACKERS + PHD_TRACKERS)
@pytest.mark.parametrize("scan, message", [
    (None, r"step takes a scan \(nnda\.data\.dataset\.Scan: index, time, measurements, sensor\), got NoneType"),
    ((1, 2.0, np.empty((0, 2))), r"step takes a scan .* got tuple"),
    (Scan(1, "2.0", np.empty((0, 2))), r"scan 1 has time '2\.0' of type str; a scan's time is a number of seconds"),
    (Scan(1, None, np.empty((0, 2))), r"scan 1 has time None of type NoneType"),
    (Scan(1, float("nan"), np.empty((0, 2))), r"scan 1 has a non-finite time nan"),
])
def test_a_scan_that_is_not_one_is_refused(name, scan, message):
    with pytest.raises(TrackingError, match=rf"^{name}: .*{message}"):
        _tracker(name).step(scan)


def test_position_fixes_are_checked_for_their_own_kind():
    tracker = make_tracker("gnn", Sensor(kind="position", sigma_position_m=5.0, name="fixes"))
    tracker.step(Scan(1, 2.0, np.array([[-100.0, 50.0]])))  # a negative x is a position, not a bad range
    with pytest.raises(TrackingError, match=r"^gnn: scan 2 of sensor of position fixes 'fixes': measurements must "
                                            r"have shape \(N, 2\) \[x m, y m\], one row per contact, got \(0, 3\)"):
        tracker.step(Scan(2, 4.0, np.empty((0, 3))))
    with pytest.raises(TrackingError, match=r"contact 0 is invalid \[nan, 1\.0\] \(non-finite\); give finite values$"):
        tracker.step(Scan(2, 4.0, np.array([[np.nan, 1.0]])))


def test_a_phd_filter_given_fixes_checks_them_as_fixes():
    tracker = GMPHDTracker(Sensor(), measurement=PositionMeasurement(((40.0**2, 0.0), (0.0, 40.0**2))))
    tracker.step(Scan(1, 2.0, np.array([[-5_000.0, -3_000.0]])))  # negative coordinates are fine
    for z, message in [(np.array([["x", "y"]]), r"scan 2 of sensor of position fixes 'radar': measurements must be "
                                                r"real numbers .* \[x m, y m\] per contact; got dtype <U1"),
                       (np.empty((0, 3)), r"must have shape \(N, 2\) \[x m, y m\], one row per contact, got \(0, 3\)"),
                       (np.array([[1.0, np.inf]]), r"contact 0 is invalid \[1\.0, inf\] \(non-finite\)")]:
        with pytest.raises(TrackingError, match=rf"^gmphd: .*{message}"):
            tracker.step(Scan(2, 4.0, z))


def test_every_refusal_is_an_nnda_error_and_a_value_error():
    """Callers that caught numpy's ValueError still catch these."""
    with pytest.raises(NndaError):
        _tracker("gnn").step(Scan(1, 2.0, np.array([["a", "b"]])))
    with pytest.raises(ValueError):
        nnda.track(None, "gnn")
