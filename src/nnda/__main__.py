"""``python -m nnda`` runs the command line."""

from nnda.cli import main

main()
