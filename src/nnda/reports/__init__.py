"""Pictures, tables and reports: a dataset's plot, the association network's tables, a study's report.

``pages`` holds the page model (`Section`, lazily drawn `Figure`s, the
Markdown and HTML pages); ``text_table`` holds `TextTable` (console,
Markdown and HTML renderings) and the one ``mean [low, high]`` formatter;
``classifier_tables`` the association network's tables; ``scenario_plot``
draws one dataset; ``study_report`` writes a study directory's
``report.md`` and self-contained ``report.html``, each job kind's sections
from its registry: the tracker jobs' in ``track_report`` (with
``study_tables``, ``study_figures`` (matplotlib PNGs), ``trajectory_plot``
(plotly, offline), ``study_summary``, ``headline`` and the optional
sections), the particle-filter and pedestrian studies' in
``reentry_section``, ``tbd_section`` and ``pedestrian_section``;
``claims`` and ``reproduction`` read the reference works' claims against a
reproduction's studies. No command is defined here (`nnda.app`).
"""
