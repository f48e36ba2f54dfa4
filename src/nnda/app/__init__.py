"""The application layer: every ``nnda`` command (`nnda.app.cli`) and the public Python API (`nnda.app.api`).

It sits above the library's layers (data, filters, models, tracking,
study, reports) and is the only place a command is defined. Nothing is
imported here.
"""
