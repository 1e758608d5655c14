"""`python -m impactgen.cli`: the `impactgen` command."""
import sys

from . import main

sys.exit(main())
