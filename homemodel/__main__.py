"""`python -m homemodel` runs the command line, as the `homemodel` script does."""

import sys

try:
    from homemodel.cli.launcher import main
except KeyboardInterrupt:  # Ctrl-C before the launcher's own handling: as quiet as after it
    print("interrupted", file=sys.stderr)
    sys.exit(130)

main()
