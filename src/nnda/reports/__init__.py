"""Pictures, tables and reports: a dataset's plot, the association network's tables, a study's report.

``pages`` holds the page model (`Section`, `Figure`, the Markdown and HTML pages);
``text_table`` holds `TextTable` (console, Markdown and HTML renderings)
and the one ``mean [low, high]`` formatter; ``classifier_tables`` the
association network's tables; ``scenario_plot`` draws one dataset;
``study_report`` writes a study's ``report.md`` and self-contained
``report.html`` from ``study_tables`` (a table per scenario, rows from
`nnda.study.measures`), ``study_figures`` (matplotlib PNGs),
``trajectory_plot`` (plotly, offline), ``study_summary`` (who wins where),
the optional sections (``features_section``, ``ablation_section``,
``peers_section``) and ``spec_values`` (the thesis's tables);
``commands`` holds ``nnda compare``, ``nnda report`` and ``nnda
plot-scenario``, ``model_commands`` ``nnda train`` and ``nnda evaluate``.
"""
