"""``python -m graphpose``: the command line (see :mod:`graphpose.cli`)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
