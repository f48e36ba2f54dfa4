"""Multi-target trackers: the shared framework and the association methods.

``nnda.tracking.registry.make_tracker(name, sensors, params)`` builds any
registered tracker (``gnn``, ``jpda``, ``mht``, ``nn``); each consumes scans
with ``step(scan)`` and returns a `nnda.tracking.output.TrackerOutput`.
Modules: ``tracker`` (the protocol and the single-hypothesis framework),
``lifecycle``, ``gating``, ``assignment``, ``clutter_density``, one module
per method and ``registry``. Nothing is imported here.
"""
