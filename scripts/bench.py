#!/usr/bin/env python
"""Benchmarks: graphpose beside its peer (OpenCV), medians and ratios, in one run.

    python scripts/bench.py [SECTION ...] [--quick]

SECTION is any of: junctions, pose, tracking (default: all). Each section lives in
``scripts/bench_<section>.py`` and prints its own table. OpenCV is the peer only here:
install it with ``pip install -e ".[bench]"``. Wall times depend on the machine; every figure
is measured in this run, never typed in.
"""

import argparse
import importlib
import platform
import sys
from pathlib import Path

SECTIONS = ("junctions", "pose", "tracking")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sections", nargs="*", metavar="SECTION", help=f"any of {', '.join(SECTIONS)} (default: all)")
    parser.add_argument("--quick", action="store_true", help="fewer trials, for a smoke run")
    args = parser.parse_args(argv)
    # argparse checks an empty nargs="*" default against choices, so SECTION is checked here.
    unknown = [s for s in args.sections if s not in SECTIONS]
    if unknown:
        parser.error(f"unknown section(s) {', '.join(unknown)}; choose from {', '.join(SECTIONS)}")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    print(f"# graphpose benchmark on {platform.node()} ({platform.processor() or platform.machine()}), "
          f"Python {platform.python_version()}")
    for name in args.sections or SECTIONS:
        module = importlib.import_module(f"bench_{name}")
        print(f"\n## {name}\n", flush=True)
        module.main(quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
