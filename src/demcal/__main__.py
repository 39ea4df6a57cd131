"""``python -m demcal`` runs the command line."""

from demcal.cli import main

main()
