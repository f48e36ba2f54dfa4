"""Single-object estimation, batched over K objects: no track management here.

Modules: ``motion`` (CV and CT motion models), ``measurement`` (polar and
Cartesian measurement models), ``kalman`` (the batched KF/EKF steps),
``two_point`` (a CV start from two fixes), ``imm`` (the interacting multiple
model over the motion models), ``batch`` (records of per-object arrays),
``particle`` (the particle engine: resampling, state-space models, SMC),
``reentry`` (the seed-004 re-entry model's particle-filter model and its
EKF/UKF/converted-KF baselines) and ``ground_motion`` (seed-000's pedestrian
models: the thesis's CV, modified NCSHT, the HM-map model).
Nothing is imported here, so ``import nnda.filters.kalman`` loads neither
pyarrow nor the trackers.
"""
