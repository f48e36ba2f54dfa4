"""Pictures and reports: a dataset's plot, and the report of a comparison study.

``scenario_plot`` draws one dataset; ``study_report`` writes a study's
``report.md`` and self-contained ``report.html`` from ``study_tables``,
``study_figures`` (matplotlib PNGs), ``trajectory_plot`` (plotly, offline),
``study_summary`` (who wins where) and ``spec_values`` (the thesis's
tables); ``commands`` holds ``nnda plot-scenario`` and ``nnda report``.
"""
