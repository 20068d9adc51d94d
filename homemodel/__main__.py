"""`python -m homemodel` runs the command line, as the `homemodel` script does."""

from homemodel.launcher import main

main()
