"""``python -m nnda`` runs the command line."""

from nnda.app.cli import main

main()
