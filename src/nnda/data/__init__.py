"""Scenarios, the sensor models, the generator and datasets on disk.

Modules: ``scenario`` (the validated scenario config: sensors with their
clutter, targets), ``trajectory`` (noise-free target paths), ``sensor``
(coordinate transforms about a sensor, coverage and measurement noise), ``clutter``,
``generator`` (seeded datasets), ``presets`` (the reference scenarios),
``dataset`` (records and their Parquet files), ``commands`` (CLI) and the
``pedestrian`` package (Frencl (2014)'s walkers).
Nothing is imported here, so ``import nnda.data.sensor`` loads neither
pyarrow nor scipy.
"""
