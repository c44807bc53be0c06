"""``python -m biplan`` runs the command-line interface."""

from biplan.cli.main import main

main()
