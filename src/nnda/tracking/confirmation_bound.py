"""The least confirmation delay a single-scan-likelihood rule can have: a clairvoyant SPRT.

Feed Wald's test on the track score (`nnda.tracking.lifecycle`) only the
true target's contacts, with a perfect prediction (innovation covariance S
= R, the measurement noise: any real track's S is larger, and its ratios
smaller). Each scan then adds, with the target's true detection
probability P_D* and the gate's P_G,

    z = ln(P_D l / lambda)   w.p. P_D* P_G, l = N(nu; 0, S), nu inside the gate
    z = ln(1 - P_D P_G)      otherwise (`nnda.tracking.marginals.log_miss_weight`)

so the drift per scan is (`scan_drift`)

    mu = P_D* P_G [ln(P_D / lambda) - ln(2 pi) - ln|S| / 2 - E[d^2 | d^2 < g] / 2]
         + (1 - P_D* P_G) ln(1 - P_D P_G),

E[d^2 | d^2 < g] = 2 - g e^{-g/2} / (1 - e^{-g/2}) on 2 dof (`gated_mean_square`).
From the start score s0 to Wald's thresholds (b, a) the expected number of
tests under "target" is, overshoot neglected (Wald 1947; `expected_tests`),

    E[N] = ((1 - beta) (a - s0) + beta (b - s0)) / mu,

a lower bound on any rule with those error probabilities fed the same
contacts. The first test comes on the third scan of a target's life (an
initiator, then the two-point start), so the delay from first detection to
confirmation is at least (1 + E[N]) scan periods (`delay_bound_s`). Usage::

    mu = scan_drift(pd_true=1.0, pd=0.9, gate=9.21, log_det_s=2 * log(30 * 45), density=8.7e-7)  # per scan
    n = expected_tests(start, lower, upper, mu, beta)                 # tests, >= 1 in practice
    delay = delay_bound_s(n, scan_period=2.0)                         # s
    clairvoyant_delay_s("score", lifecycle, 8.7e-7, 17_500.0, 30.0, 3e-3, 2.0)   # the three steps, in s

The start and thresholds are the rule's (`clairvoyant_delay_s`): the score
rule starts at the two-point ratio ln(P_D / (A_w rho)) and tests against
Wald's thresholds (the adaptive rule: its threshold for the clutter density
``density``); the existence rule adds the birth prior, loses ln s per
scan to the survival (its exact loss at small existence, an upper bound
on the drift) and confirms at ``existence_confirmation``.

Units: ``density`` lambda and ``log_det_s`` ln|S| in one measurement space
(Cartesian m^-2 and ln m^4 here; a polar radar's (m rad) gives the same z,
lambda and |S|^(1/2) each scaling by the range).
"""

from __future__ import annotations

import math

import numpy as np

from nnda.tracking.lifecycle import LifecycleConfig, adaptive_threshold, birth_log_odds, sprt_thresholds
from nnda.tracking.marginals import log_miss_weight


def gated_mean_square(gate: float) -> float:
    """E[d^2 | d^2 < gate] for d^2 chi-square on 2 dof: the mean squared Mahalanobis distance of a
    target's contact that falls inside a gate of that size."""
    tail = math.exp(-0.5 * gate)
    return 2.0 - gate * tail / (1.0 - tail)


def contact_log_ratio_mean(pd: float, gate: float, log_det_s: float, density: float) -> float:
    """E[ln(P_D l / lambda)] over the target's contacts inside the gate, l = N(nu; 0, S) with ln|S| =
    ``log_det_s`` and clutter density ``density`` (same measurement space)."""
    return math.log(pd / density) - math.log(2.0 * math.pi) - 0.5 * log_det_s - 0.5 * gated_mean_square(gate)


def scan_drift(pd_true: float, pd: float, gate: float, log_det_s: float, density: float) -> float:
    """Mean score increment per scan of the target's track (module docstring): a contact in the gate with
    probability ``pd_true`` P_G, else the miss weight ln(1 - P_D P_G) of the rule's ``pd``."""
    hit = pd_true * (1.0 - math.exp(-0.5 * gate))
    return hit * contact_log_ratio_mean(pd, gate, log_det_s, density) + (1.0 - hit) * log_miss_weight(pd, gate)


def expected_tests(start: float, lower: float, upper: float, drift: float, beta: float) -> float:
    """Wald's expected number of tests under "target" from score ``start`` to thresholds (``lower``,
    ``upper``) at mean increment ``drift`` > 0, deleting a target's track with probability ``beta``:
    ((1 - beta)(upper - start) + beta (lower - start)) / drift, overshoot neglected (a lower bound)."""
    if drift <= 0:
        raise ValueError(f"the score's drift under 'target' must be positive, got {drift:g}: no finite delay")
    return max(((1.0 - beta) * (upper - start) + beta * (lower - start)) / drift, 0.0)


def delay_bound_s(tests: float, scan_period: float) -> float:
    """Seconds from a target's first detection to its confirmation after ``tests`` tests: the initiator's
    scan, the two-point start's, then one test per scan: (1 + tests) scan periods."""
    return (1.0 + tests) * scan_period


def clairvoyant_delay_s(rule: str, lifecycle: LifecycleConfig, density: float, range_m: float,
                        sigma_range_m: float, sigma_azimuth_rad: float, scan_period: float, pd: float = 0.9,
                        gate: float = 9.21, pd_true: float = 1.0, coverage_m2: float = 1.0) -> float:
    """Least mean delay (s) from first detection to confirmation of a target at ``range_m`` from a polar
    radar of noise ``sigma_range_m``, ``sigma_azimuth_rad`` and ``scan_period`` (s) in clutter of area
    density ``density`` (m^-2) under ``rule`` "adaptive", "score" or "existence" of ``lifecycle`` (module docstring);
    ``coverage_m2`` is the sensor's coverage area, for the existence rule's birth prior."""
    log_det_s = 2.0 * math.log(sigma_range_m * sigma_azimuth_rad * range_m)  # S = R, as a Cartesian area
    drift = scan_drift(pd_true, pd, gate, log_det_s, density)
    start = math.log(pd / (lifecycle.window_area(scan_period, sigma_range_m) * density))
    if rule == "score":
        lower, upper = lifecycle.score_thresholds
    elif rule == "adaptive":
        lower = lifecycle.score_thresholds[0]
        at = np.array([float(density)])
        upper = float(adaptive_threshold(lifecycle.false_track_rate, lifecycle.false_deletion, at, scan_period)[0])
    elif rule == "existence":
        start += float(birth_log_odds(pd, lifecycle.new_targets_per_scan / coverage_m2, density))
        lower = start + sprt_thresholds(lifecycle.false_confirmation, lifecycle.preliminary_false_deletion)[0]
        c = lifecycle.existence_confirmation
        upper = math.log(c) - math.log1p(-c)
        drift += math.log(lifecycle.survival_probability)
    else:
        raise ValueError(f"rule must be 'adaptive', 'score' or 'existence', got {rule!r}")
    return delay_bound_s(expected_tests(start, lower, upper, drift, lifecycle.false_deletion), scan_period)
