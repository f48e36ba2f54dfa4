"""Birth intensities of the PHD trackers: measurement-driven (the default) and static.

Measurement-driven (adaptive) birth, after Ristic, Clark, Vo & Vo,
"Adaptive target birth intensity for PHD and CPHD filters", IEEE TAES
48(2), 2012: after the update of scan k, each contact z_i is explained by
the filter's components to the extent e_i = sum_j w_j(z_i) of its detection
copies' weights (the posterior probability that it came from a target,
given the model); the newborn intensity of scan k + 1 puts a component on
each contact with weight

    nu_b (1 - e_i) / sum_l (1 - e_l)      (nu_b: expected births per scan),

position from the contact (its Cartesian fix and covariance), velocity 0
with standard deviation ``speed_sigma`` per axis (in the motion model's
state: `MotionModel.newborn`; a heading state [x, y, v, alpha] spreads it
over a ring of headings), at the time of scan k; the
tracker predicts it to scan k + 1 like every other component (without the
survival factor) and drops its missed copy there (a newborn is taken to be
detected at its first update, as Stone Soup's PHD updater does too). The
filter is given no truth.

A sensor's first sweep has no earlier sweep to explain its contacts, and
the targets present from the start are among them: each of its contacts
gets a newborn of weight 1/n^2 (`first_sweep_births`), n the contacts in the
square of half-side ``clutter_radius_m`` around it (itself included, as the
``local`` clutter estimate counts them). A lone contact (n = 1) is then as
likely a target as not, more than one target to a square is taken as
unlikely, and in dense clutter the newborns stay light: the square falls in
from 1/n (one target among the square's contacts) so that at 1,000 clutter
points a scan (n near 10) a clutter contact's newborn, at 0.01, starts no
more false tracks than the later sweeps' births do (measured on S1-S6, 5
runs: 1/n added 0.2-0.6 false tracks a run at 1,000 clutter, 1/n^2 none
beyond one run in five). Targets present from the start are then reported
a few sweeps sooner: mean GOSPA 8-22 m lower on S1-S6 at 100 and 1,000
clutter, and at 1,000 aircraft over a 250 km radar the EK-PHD's MOTA rises
from 0.52 to 0.64 (`benchmarks/bench_scale.py`). ``first_sweep_births =
false`` gives the first sweep the later sweeps' births.

Static birth (Vo & Ma 2006's gamma_k; `nnda.tracking.phd.config.StaticBirth`,
added by the tracker) puts fixed components at the scan time; placed at the
targets' true initial states and given at the first scan only, it is the
oracle birth of Frencl (2014) (the caller builds it from the truth; the
tracker never reads truth).
"""

from __future__ import annotations

import numpy as np

from nnda.filters.mixture import Mixture
from nnda.filters.motion import MotionModel
from nnda.tracking.clutter_density import local_density


def measurement_births(xy: np.ndarray, cov: np.ndarray, explained: np.ndarray, rate: float, speed_sigma: float,
                       motion: MotionModel, first_label: int) -> Mixture:
    """Newborn components from contacts at Cartesian ``xy`` (N, 2) m with covariances ``cov`` (N, 2, 2),
    each explained to ``explained`` (N,) in [0, 1]: weights ``rate`` (1 - e_i) / sum (1 - e), velocity 0
    +/- ``speed_sigma`` m/s, in ``motion``'s state (`MotionModel.newborn`: a contact's weight is shared by
    the components the model puts on it), labels from ``first_label`` on. Contacts fully explained get
    no component."""
    free = np.clip(1.0 - explained, 0.0, 1.0)
    total = free.sum()
    if total <= 0:
        return Mixture.empty(motion.dim)
    return _newborn(xy, cov, free, rate, total, speed_sigma, motion, first_label)


def first_sweep_births(xy: np.ndarray, cov: np.ndarray, radius: float, speed_sigma: float, motion: MotionModel,
                       first_label: int) -> Mixture:
    """Newborn components from a sensor's first sweep of contacts at ``xy`` (N, 2) m with covariances ``cov``
    (N, 2, 2): weight 1/n^2 on each, n the contacts in the square of half-side ``radius`` m around it (module
    docstring); otherwise as `measurement_births`."""
    count = local_density(xy, xy, radius) * (2.0 * radius) ** 2
    return _newborn(xy, cov, 1.0 / np.maximum(count, 1.0) ** 2, 1.0, 1.0, speed_sigma, motion, first_label)


def _newborn(xy: np.ndarray, cov: np.ndarray, share_of: np.ndarray, mass: float, total: float, speed_sigma: float,
             motion: MotionModel, first_label: int) -> Mixture:
    """Components on the contacts at ``xy`` with ``cov``: contact i's weight ``mass`` share_of_i / ``total``
    ((N,); those of share 0 left out), shared by the components the motion model puts on it, velocity 0
    +/- ``speed_sigma`` m/s in ``motion``'s state, labels from ``first_label`` on."""
    keep = np.flatnonzero(share_of > 0)
    if not len(keep):
        return Mixture.empty(motion.dim)
    x, P, of = motion.newborn(xy[keep], cov[keep], speed_sigma)
    share = np.bincount(of, minlength=len(keep))[of]
    w = mass * share_of[keep][of] / (total * share)
    return Mixture(w, x, P, np.arange(first_label, first_label + len(w), dtype=np.int64))
