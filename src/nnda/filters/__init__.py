"""Single-object estimation, batched over K objects: no track management here.

Modules: ``motion`` (CV and CT motion models), ``measurement`` (polar and
Cartesian measurement models), ``kalman`` (the batched KF/EKF steps),
``two_point`` (a CV start from two fixes), ``imm`` (the interacting multiple
model over the motion models) and ``batch`` (records of per-object arrays).
Nothing is imported here, so ``import nnda.filters.kalman`` loads neither
pyarrow nor the trackers.
"""
