"""How the Stone Soup peers are set up and matched to our trackers: one table for the docs and the report.

Kept free of Stone Soup imports so the report can print it anywhere.
"""

from __future__ import annotations

#: our tracker kind -> its nearest Stone Soup equivalent (speed ratios are taken against it)
EQUIVALENT = {"gnn": "stonesoup-gnn", "jpda": "stonesoup-jpda", "gmphd": "stonesoup-gmphd",
              "ekphd": "stonesoup-gmphd", "ukphd": "stonesoup-gmphd", "cphd": "stonesoup-gmphd"}

#: (part, Stone Soup component and setting, what it is matched to in nnda)
MATCHING = (
    ("measurement", "per sensor, carried by its detections: a polar radar's CartesianToBearingRange, mapping (2, 0) "
     "and translation_offset (y_s, x_s): bearing = atan2(x - x_s, y - y_s), our azimuth clockwise from north; noise "
     "diag(sigma_az^2, sigma_r^2); a position sensor's LinearGaussian on (x, y), noise sigma_position^2 I",
     "the dataset's Sensors (30 m, 3 mrad in the single-radar presets)"),
    ("motion", "CombinedLinearGaussianTransitionModel of two ConstantVelocity (white-noise acceleration), "
     "q = sigma_q^2 T per axis with T the shortest scan period of the sensors, sigma_q = 10 m/s^2",
     "our IMM (CV 3.5 m/s^2 + CT 5 m/s^2): Stone Soup has no IMM; one CV model at our "
     "CV's 3.5 m/s^2 lost targets in the turns of S1, S3 and S5 (no clutter), 10 m/s^2 kept every one"),
    ("filter", "ExtendedKalmanPredictor, ExtendedKalmanUpdater", "the EKF inside our IMM"),
    ("gate", "GNN: DistanceHypothesiser, Mahalanobis, missed_distance sqrt(9.21); JPDA: PDAHypothesiser, "
     "prob_gate 0.99", "chi-square 9.21 on 2 dof (P_G = 0.99)"),
    ("association", "GNNWith2DAssignment / JPDA (exact joint events) with Gaussian-mixture reduction "
     "(MultiTargetTracker / MultiTargetMixtureTracker)", "gnn / jpda"),
    ("P_D, clutter (JPDA)", "prob_detect 0.9; clutter_spatial_density per scan: mean over the scan's contacts "
     "of the contacts per m^2 in a 3 km half-side square, times range, in (m rad)^-1",
     "our jpda: pd 0.9, 'local' density in the same square"),
    ("initiation", "MultiMeasurementInitiator: every unused contact opens a held track (velocity 0, std "
     "v_max/2 = 100 m/s per axis) associated by GNN inside the initiator; released (confirmed) at M+2 = 5 "
     "updates, dropped after N-M+1 = 2 scans without one (UpdateTimeStepsDeleter)",
     "two-point start + M/N = 3/4: confirmed at the 5th contact at the earliest"),
    ("deletion", "UpdateTimeStepsDeleter(max_misses + 1 = 4), counting only the scans whose sensor covers the "
     "track (as the initiator's deleter)", "confirmed tracks survive 3 misses, deleted at the 4th; a sensor that "
     "does not cover a track counts no miss"),
    ("GM-PHD (stonesoup-gmphd)", "PointProcessMultiTargetTracker: GaussianMixtureHypothesiser over a "
     "DistanceHypothesiser (Mahalanobis, missed_distance sqrt(50)), PHDUpdater around an ExtendedKalmanUpdater, "
     "GaussianMixtureReducer", "ekphd: the same recursion on the gated (component, contact) pairs, batched"),
    ("GM-PHD motion, P_S, P_D", "one CV model, q = sigma_q^2 T with sigma_q = 10 m/s^2; prob_survival 0.99 per "
     "shortest scan period, prob_detection 0.9 (the scan's sensor's); components outside the sweeping sensor's "
     "coverage are left out of its update, predicted and weighted by p_S", "ekphd's CV model (10 m/s^2), p_S 0.99, "
     "p_D 0.9, 0 outside the sweeping sensor's coverage"),
    ("GM-PHD clutter", "clutter_spatial_density set each scan to the mean of our per-contact local intensities "
     "(per m rad)", "ekphd: each contact's own local intensity (contacts in a 3 km half-side square, times range)"),
    ("GM-PHD birth", "Stone Soup has no measurement-driven birth: our newborn components go into its mixture as "
     "births, one per contact of the previous scan, weight 0.1 / N, velocity 0 +/- 100 m/s per axis; its own "
     "birth component weighs 0", "ekphd: the same newborn components weighted by how little the filter explains "
     "each contact, 0.1 (1 - e_i) / sum (1 - e)"),
    ("GM-PHD reduction", "GaussianMixtureReducer: prune 1e-5 (keeps w >= T and spreads the pruned weight over "
     "the rest), merge 4 under the candidate's covariance with merged weights capped at 1, at most 100 "
     "components; extraction_threshold 0.5 (w > 0.5)", "the radar preset: prune w <= 1e-5 (the weight is "
     "dropped), merge 4 under the candidate's covariance (weights not capped), J_max 100, extraction w >= 0.5"),
    ("GM-PHD bearings", "PHDUpdater evaluates the likelihood of the raw bearing difference (not wrapped): "
     "contacts go in with azimuths in [-pi, pi), so a target crossing due south loses its likelihood there",
     "every azimuth residual wrapped"),
    ("stonesoup-mfa", "not offered yet: Stone Soup's MFA (MFAHypothesiser, MFADataAssociator) needs ortools, "
     "which the peers extra does not install, and keeps Gaussian-mixture tracks that its tracker classes do "
     "not drive: the per-scan mixture update and the hand-over from the initiator would be our own glue "
     "rather than Stone Soup's components; with the GNN and JPDA peers already near 1 s per scan on S1-S6 "
     "it did not fit this round", "mht"),
)
