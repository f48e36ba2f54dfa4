"""Scenarios, the radar model, the generator and datasets on disk.

Modules: ``scenario`` (the validated scenario config: sensor, clutter,
targets), ``trajectory`` (noise-free target paths), ``sensor`` (coordinate
transforms, coverage and the radar's measurement noise), ``clutter``,
``generator`` (seeded datasets), ``presets`` (the reference scenarios),
``dataset`` (records and their Parquet files) and ``commands`` (CLI).
Nothing is imported here, so ``import nnda.data.sensor`` loads neither
pyarrow nor scipy.
"""
