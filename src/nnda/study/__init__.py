"""Studies: many runs of many estimators on the same data, measured and aggregated, by one engine.

The engine, in data-flow order: ``config`` (the study file, composed from
the job kinds' fields), ``kinds`` (the registry of job kinds: ``track``,
``filter``, ``reentry``, ``tbd``, ``pedestrian``; the contract in
``kinds.base``), ``plan`` (every input checked, the independent jobs,
keyed), ``runner`` (jobs in-process, on local processes or on Dask, each
record in its own file, resume, the lock), ``results`` (each kind's
aggregates, ``summary.json``, ``timing.json``) with ``checksums`` (every
file written and checked), ``compare`` (all of it). Shared by the kinds:
``stats`` (intervals and tests), ``measures`` (the one measure registry),
``timing`` (wall-clock entries apart). The kinds' science: ``track_job``,
``track_results``, ``metrics``, ``gospa``, ``matching``, ``cardinality``,
``loss_causes``, ``classifier`` (tracker jobs), ``filter_run`` (filter
jobs), ``reentry``, ``tbd`` with ``tbd_runs`` and ``tbd_chain``,
``pedestrian`` with ``pedestrian_scores``. Nothing is imported here.
"""
