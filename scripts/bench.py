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
import importlib.metadata
import os
import platform
import subprocess
import sys
from pathlib import Path

SECTIONS = ("junctions", "pose", "tracking")
#: Distributions whose versions move the figures; OpenCV ships under several names.
PACKAGES = (("graphpose", ("graphpose",)), ("numpy", ("numpy",)), ("scipy", ("scipy",)),
            ("scikit-image", ("scikit-image",)), ("gtsam", ("gtsam",)),
            ("OpenCV", ("opencv-python-headless", "opencv-python", "opencv-contrib-python-headless",
                        "opencv-contrib-python")))


def _version(distributions):
    """Installed version of the first of ``distributions`` found, else "not installed"."""
    for name in distributions:
        try:
            version = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
        return f"{version} ({name})" if len(distributions) > 1 else version
    return "not installed"


def _commit():
    """Short git commit of the repository, marked when the working tree differs from it."""
    repo = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "-C", str(repo), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(repo), "diff", "--quiet", "HEAD"]).returncode != 0
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + (" + uncommitted changes" if dirty else "")


def header() -> str:
    """The run's machine, Python and package versions, as markdown."""
    versions = ", ".join(f"{label} {_version(names)}" for label, names in PACKAGES)
    return (f"# graphpose benchmark on {platform.node()} ({platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} cores), Python {platform.python_version()}\n\n"
            f"Versions: {versions}; commit {_commit()}.")


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
    print(header())
    for name in args.sections or SECTIONS:
        module = importlib.import_module(f"bench_{name}")
        print(f"\n## {name}\n", flush=True)
        module.main(quick=args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
