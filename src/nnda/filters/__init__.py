"""Single-object estimation, batched over K objects: no track management here.

Modules: ``motion`` (CV and CT motion models), ``measurement`` (polar and
Cartesian measurement models), ``kalman`` (the batched KF/EKF steps),
``two_point`` (a CV start from two fixes), ``imm`` (the interacting multiple
model over the motion models), ``batch`` (records of per-object arrays),
``particle`` (the particle engine: resampling, state-space models, SMC),
``reentry`` (the ballistic re-entry model of Pavlov & Bruno (2003) for the
particle filters and its EKF/UKF/converted-KF baselines), ``tbd`` (track-
before-detect in image frames, Bruno, Araújo & Pavlov: the mixed-state model
and its particle filters), ``frame_likelihood`` (its compiled frame
likelihood) and ``ground_motion`` (the pedestrian models of Frencl (2014):
CV, modified NCSHT, the HM-map model).
Nothing is imported here, so ``import nnda.filters.kalman`` loads neither
pyarrow nor the trackers.
"""
