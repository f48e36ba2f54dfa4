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


def measurement_births(xy: np.ndarray, cov: np.ndarray, explained: np.ndarray, rate: float, speed_sigma: float,
                       motion: MotionModel, first_label: int) -> Mixture:
    """Newborn components from contacts at Cartesian ``xy`` (N, 2) m with covariances ``cov`` (N, 2, 2),
    each explained to ``explained`` (N,) in [0, 1]: weights ``rate`` (1 - e_i) / sum (1 - e), velocity 0
    +/- ``speed_sigma`` m/s, in ``motion``'s state (`MotionModel.newborn`: a contact's weight is shared by
    the components the model puts on it), labels from ``first_label`` on. Contacts fully explained get
    no component."""
    free = np.clip(1.0 - explained, 0.0, 1.0)
    total = free.sum()
    keep = np.flatnonzero(free > 0)
    if total <= 0 or not len(keep):
        return Mixture.empty(motion.dim)
    x, P, of = motion.newborn(xy[keep], cov[keep], speed_sigma)
    share = np.bincount(of, minlength=len(keep))[of]
    w = rate * free[keep][of] / (total * share)
    return Mixture(w, x, P, np.arange(first_label, first_label + len(w), dtype=np.int64))
