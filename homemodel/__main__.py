"""`python -m homemodel` runs the command line, as the `homemodel` script does."""

from homemodel.cli.launcher import main

main()
