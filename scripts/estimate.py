#!/usr/bin/env python
"""Estimate the camera pose from checkerboard images: ``graphpose estimate`` as a script.

    python scripts/estimate.py                      # the bundled example, data/cases.json
    python scripts/estimate.py IMAGE --bounds u1,v1,u2,v2,u3,v3,u4,v4 [--K ...] [--board ...]
    python scripts/estimate.py --cases CASES.json [--json OUT.json] [--overlay FOLDER]

Every option is the command's: see ``python scripts/estimate.py --help``.
"""

import sys

from graphpose.cli import main

if __name__ == "__main__":
    sys.exit(main(["estimate", *sys.argv[1:]]))
