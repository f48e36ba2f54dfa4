"""Comparison studies: which trackers on which scenarios, run many times, measured and aggregated.

Modules, in data-flow order: ``config`` (the study file), ``plan`` (every
input checked, the independent jobs), ``job`` (one tracker over one run,
timed and scored), ``runner`` (jobs in-process, on local processes or on
Dask, each result in its own file, resume), ``metrics`` and ``gospa`` (a
run's measures), ``results`` (tables and means with intervals),
``classifier`` (the model files' figures), ``compare`` (all of it, then
the report) and ``commands`` (``nnda compare``). Nothing is imported here.
"""
