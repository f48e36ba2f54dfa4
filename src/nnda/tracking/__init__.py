"""Multi-target trackers: the shared framework and the association methods.

``nnda.tracking.registry.make_tracker(name, sensors, params)`` builds any
registered tracker (``gnn``, ``jpda``, ``mht``, ``nn``); each consumes scans
with ``step(scan)`` and returns a `nnda.tracking.output.TrackerOutput`.
Modules: ``tracker`` (the protocol and the single-hypothesis framework),
``lifecycle`` (confirmation and deletion rules, the sanity and track-quality
deletions), ``lag`` (the fixed-lag output of any tracker), ``gating``,
``assignment``, ``clutter_density``, one module per method, ``phd`` (the PHD
family) and ``registry``. Nothing is imported here.
"""
