"""`python -m opendyn.cli`: the `opendyn` command."""

import sys

from .main import main

sys.exit(main())
