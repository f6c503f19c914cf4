"""``python -m hisopt`` runs the command line."""

from hisopt.cli import main

main()
