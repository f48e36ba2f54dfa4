"""Scenes and checks the labelled RFS trackers' tests share (pmbm, glmb, lmb)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from nnda.data.dataset import Dataset, Scan
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import BoundWarning
from nnda.filters.imm import IMM
from nnda.study.metrics import run_metrics
from nnda.tracking.output import TrackerOutput, TrackStatus
from nnda.tracking.registry import make_tracker

#: a position sensor (50 m noise) without clutter
POSITION = Sensor(kind="position", sigma_position_m=50.0, clutter=Clutter(law="none"))

#: two targets 150 m apart flying east at 100 m/s, seen by `POSITION`: scans 1-2 open the tracks (four pairs:
#: each contact of scan 2 in both initiators' windows), scans 3-4 are ambiguous (every contact in every gate:
#: the gate is unbounded here)
TWO = [np.array(points, float) for points in (
    [(10_000.0, 10_000.0), (10_000.0, 10_150.0)],
    [(10_210.0, 10_010.0), (10_190.0, 10_140.0)],
    [(10_420.0, 10_060.0), (10_380.0, 10_110.0)],
    [(10_610.0, 10_090.0), (10_600.0, 10_070.0), (10_590.0, 10_400.0)])]


def two_scans() -> list[Scan]:
    """`TWO` as scans 1-4, 2 s apart."""
    return [Scan(k + 1, 2.0 * (k + 1), z) for k, z in enumerate(TWO)]


def one_target() -> tuple[Sensor, list[Scan]]:
    """A radar of P_D 1 without clutter and the scans of one manoeuvring target (60 s, one contact a scan)."""
    sensor = Sensor(pd=1.0, clutter=Clutter(law="none"))
    target = Target(name="t", x_m=4_000.0, y_m=12_000.0, heading_deg=70.0, speed_m_s=180.0,
                    segments=[Segment(duration_s=30.0), Segment(duration_s=30.0, normal_accel=2.0)])
    ds = generate(Scenario(name="one", duration_s=60.0, targets=[target], sensors=(sensor,)), seed=7)
    scans = list(ds.scans())
    assert all(len(s.measurements) == 1 for s in scans)
    return sensor, scans


def dense_clutter() -> Dataset:
    """S6's radar with 1,000 clutter a scan and S6's first two targets, 60 s."""
    s6 = PRESETS["S6"]
    radar = s6.sensors[0].model_copy(update={"clutter": s6.sensors[0].clutter.model_copy(update={"count": 1000})})
    return generate(s6.model_copy(update={"duration_s": 60.0, "targets": s6.targets[:2], "sensors": (radar,)}),
                    seed=1)


def check_dense_clutter(name: str) -> None:
    """Tracker ``name`` on `dense_clutter`: both targets confirmed (hit rate 80 % or more, none lost), no false
    track."""
    ds = dense_clutter()
    tracker = make_tracker(name, ds.scenario.sensors, {})
    m = run_metrics(ds, [tracker.step(scan) for scan in ds.scans()])
    assert m.false_tracks == 0 and m.hit_rate >= 80.0 and m.lost_targets == 0


def mixture(tracker) -> dict[tuple, float]:
    """The tracker's hypotheses as weights keyed by each live label's contacts in the last two scans (None
    where the label is absent)."""
    return {tuple(None if s < 0 else tuple(tracker.table.hist[s, -2:].tolist()) for s in row): math.exp(log_w)
            for row, log_w in zip(tracker.hyp, tracker.log_w)}


def check_the_cap(name: str, field: str, **params) -> None:
    """Tracker ``name`` (and its ``params``) with its hypothesis cap ``field`` at 5 on `TWO`: never more, one
    warning, counted."""
    tracker = make_tracker(name, POSITION, {"clutter_density": 2e-8, "gate": 1e9, field: 5,
                                            "min_hypothesis_weight": 0.0, **params})
    with pytest.warns(BoundWarning, match=rf"config field {field}") as caught:
        for scan in two_scans():
            tracker.step(scan)
            assert len(tracker.log_w) <= 5
    assert sum(field in str(w.message) for w in caught) == 1
    assert tracker.n_capped >= 1 and math.isclose(np.exp(tracker.log_w).sum(), 1.0)



def imm_on_contacts(sensor: Sensor, scans: list[Scan]) -> Iterator[tuple[Scan, bool, tuple | None]]:
    """Per scan of `one_target`: the scan, whether its contact starts the track (the second one) and the IMM's
    estimate (x (4,), P (4, 4)) after it, run on the contacts alone (None at the first contact)."""
    imm = IMM.for_sensor(sensor)
    state, first, last = None, None, None
    for scan in scans:
        z = np.asarray(scan.measurements, float)
        if first is None:
            first, last = imm.measurement.cartesian(z), scan.time
            yield scan, False, None
            continue
        start = state is None
        if start:
            p2, cov2 = imm.measurement.position(z)
            state = imm.start(first, p2, cov2, scan.time - last)
        else:
            state = imm.update(imm.predict(state, scan.time - last), z)
        last = scan.time
        yield scan, start, imm.estimate(state)


def confirmed_as_the_imm(out: TrackerOutput, x: np.ndarray, P: np.ndarray) -> int:
    """1 if the one track of ``out`` is CONFIRMED, its estimate then the IMM's ``x``, ``P`` (1e-9); else 0."""
    if out.status[0] != TrackStatus.CONFIRMED:
        return 0
    np.testing.assert_allclose(out.state, x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out.covariance, P, rtol=1e-9, atol=1e-9)
    return 1


def associations(n: int, m: int, own: tuple[int, ...]) -> Iterator[tuple[int, ...]]:
    """Every choice of n tracks: per track one of its ``own`` options (negative codes) or one of m contacts, no
    contact taken twice."""
    for pick in itertools.product(*[[*own, *range(m)]] * n):
        used = [c for c in pick if c >= 0]
        if len(used) == len(set(used)):
            yield pick


def enumerated(tracker, branches: list[tuple[float, dict]], scans: list[Scan], grow: Callable[..., Iterator]
               ) -> list[tuple[float, dict]]:
    """``branches`` (log weight, tracks) grown over ``scans``: ``grow(w, tracks, scan, z, lam)`` gives the
    children of one branch, z (N, 2) the scan's contacts and lam (N,) the tracker's fixed clutter density in
    measurement space there."""
    cfg, imm = tracker.config, tracker.filter
    for scan in scans:
        z = np.asarray(scan.measurements, float)
        lam = cfg.clutter_density * imm.measurement.area_jacobian(z)
        branches = [child for w, tracks in branches for child in grow(w, tracks, scan, z, lam)]
    return branches


def posterior(branches: list[tuple[float, dict]], n: int) -> dict[tuple, float]:
    """Normalised weights of enumerated ``branches`` (log weight, {label index: (..., contacts)}), summed by
    the contacts of each of the n labels (None for a label absent from a branch)."""
    out = {}
    for w, tracks in branches:
        key = tuple(tracks[i][-1] if i in tracks else None for i in range(n))
        out[key] = np.logaddexp(out.get(key, -np.inf), w)
    total = np.logaddexp.reduce(list(out.values()))
    return {k: math.exp(v - total) for k, v in out.items()}


def check_the_posterior(tracker, want: dict[tuple, float]) -> None:
    """The tracker's hypotheses (`mixture`) are those of the enumerated posterior ``want`` (more than 100), with
    its weights (1e-9)."""
    got = mixture(tracker)
    assert len(want) > 100 and set(got) == set(want)
    for key, w in want.items():
        assert got[key] == pytest.approx(w, rel=1e-9, abs=1e-15)



#: scans (1-based) of `one_target` with the target's contact removed, and the last scan with one
GAP, END = {15, 16, 17}, 25


def gap_and_end(name: str, report_existence: float) -> tuple[dict, int, set, list]:
    """Tracker ``name`` at P_D 0.9 on `one_target` with the gap `GAP` and no contact after `END`: its outputs by
    scan, the target's track id, the scans that show it and those of them after `END`. With
    ``report_existence`` 0.5, checks that the confirmed track, missed twice in a row (existence ~0.47), is left
    out of the output, not deleted, and comes back under its id and CONFIRMED with the next contact; and that
    once its target ends it shows one coasted scan, then nothing until it is reported DELETED."""
    sensor, scans = one_target()
    empty = np.empty((0, 2))
    scans = [Scan(s.index, s.time, empty if s.index in GAP or s.index > END else s.measurements) for s in scans]
    tracker = make_tracker(name, sensor, {"clutter_density": 1e-8, "report_existence": report_existence,
                                          "lifecycle": {"estimate_pd": False}})  # held at 0.9: known existences
    shown = {s.index: tracker.step(s) for s in scans}
    track = int(shown[14].track_id[0])
    assert shown[14].status.tolist() == [TrackStatus.CONFIRMED]
    visible = {k for k, out in shown.items() if (out.track_id == track).any()}
    after_end = [k for k in visible if k > END]
    if report_existence:
        assert 15 in visible and not {16, 17} & visible  # one miss shown (existence ~0.91), then left out
        assert shown[18].track_id.tolist() == [track] and shown[18].status.tolist() == [TrackStatus.CONFIRMED]
        assert after_end[0] == END + 1 and len(after_end) <= 2
        assert all(shown[k].status.tolist() == [TrackStatus.DELETED] for k in after_end[1:])
    return shown, track, visible, after_end
