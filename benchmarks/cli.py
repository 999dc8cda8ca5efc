"""The benchmark's command: measure sections, write the JSON, render the page (``python -m benchmarks``).

The layout of the JSON and of a section's dict is described in :mod:`benchmarks`.
"""

from __future__ import annotations

import argparse
import datetime
import importlib
import importlib.metadata
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import time
from pathlib import Path

import benchmarks
from benchmarks import compare
from benchmarks._common import REPO
from benchmarks.page import current_texts, render_section, write_page

JSON_PATH = REPO / "docs" / "benchmarks.json"
PAGE_PATH = REPO / "docs" / "benchmarks.md"
SECTIONS = ("junctions", "detect", "fuzz", "noise", "pose", "lens", "calibration", "speed", "tracking", "batch", "recordings", "rigs")
#: Version of the JSON layout described in the docstring of :mod:`benchmarks`.
FORMAT = 1
#: Distributions whose versions move the figures; OpenCV ships under several names.
PACKAGES = (("graphpose", ("graphpose",)), ("numpy", ("numpy",)), ("scipy", ("scipy",)),
            ("scikit-image", ("scikit-image",)), ("gtsam", ("gtsam",)),
            ("OpenCV", ("opencv-python-headless", "opencv-python", "opencv-contrib-python-headless",
                        "opencv-contrib-python")))
INSTALL_HINT = 'pip install -e ".[bench]"'


# --- the run ---------------------------------------------------------------------------------


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
    try:
        head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "diff", "--quiet", "HEAD"], check=False).returncode != 0
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + (" + uncommitted changes" if dirty else "")


def _cpu_name():
    """The processor's model name (Linux /proc/cpuinfo), else what platform knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def header(argv, quick) -> dict:
    """The run's date, machine, Python and package versions, commit and command."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {
        "format": FORMAT,
        "quick": bool(quick),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": {"node": platform.node(), "cpu": _cpu_name(), "arch": platform.machine(),
                    "cores": os.cpu_count(), "load_before": None if load is None else [round(x, 2) for x in load]},
        "python": platform.python_version(),
        "versions": {label: _version(names) for label, names in PACKAGES},
        "commit": _commit(),
        "command": " ".join(["python -m benchmarks", *map(shlex.quote, argv)]),
    }


def clean(value):
    """``value`` with numpy scalars and arrays made plain and NaN/inf made None (JSON has neither)."""
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if hasattr(value, "tolist"):  # numpy scalar or array
        return clean(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def run(sections, quick, argv) -> dict:
    """Measure ``sections`` and return the whole document (header + one dict per section)."""
    doc = header(argv, quick)
    doc["sections"] = []
    for name in sections:
        module = importlib.import_module(f"benchmarks.{name}")
        start = time.perf_counter()
        section = module.main(quick=quick)
        if hasattr(module, "section"):  # a script with figures of its own layout
            section = module.section(section)
        section = clean({"name": name, "seconds": round(time.perf_counter() - start, 1), **section})
        doc["sections"].append(section)
        print(render_section(section), flush=True)
    return doc


def update(doc, measured) -> dict:
    """``doc`` with the sections of the run ``measured`` in place of its own of the same name.

    Each section taken from ``measured`` carries that run's header as ``"run"`` (its date, load,
    versions, commit and command), so the page can say where it differs from the document's own;
    the order is that of :data:`SECTIONS`.
    """
    run_header = {k: v for k, v in measured.items() if k != "sections"}
    fresh = {s["name"]: {**s, "run": run_header} for s in measured["sections"]}
    kept = {s["name"]: s for s in doc["sections"] if s["name"] not in fresh}
    merged = {**kept, **fresh}
    order = [n for n in SECTIONS if n in merged] + [n for n in merged if n not in SECTIONS]
    return {**doc, "sections": [merged[n] for n in order]}


# --- the command -------------------------------------------------------------------------------


def _earlier_run(path, option):
    """The JSON document of an earlier run that ``option`` needs, or None (said on stderr)."""
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        print(f"benchmarks: {option} needs the JSON of an earlier run; cannot read {path}: {exc}", file=sys.stderr)
        return None


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=benchmarks.__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sections", nargs="*", metavar="SECTION", help=f"any of {', '.join(SECTIONS)} (default: all)")
    parser.add_argument("--quick", action="store_true", help="fewer images, frames and repeats: a smoke run")
    parser.add_argument("--json", type=Path, help="where the figures go (default docs/benchmarks.json for a run "
                        "of every section and for --render; a run of some sections writes only when given this)")
    parser.add_argument("--page", type=Path, help="the page rendered from them (default: the JSON's path "
                        "with .md, docs/benchmarks.md for docs/benchmarks.json)")
    parser.add_argument("--render", action="store_true", help="measure nothing: redraw the page from the JSON (its stored texts brought up to date, figures untouched)")
    parser.add_argument("--compare", type=Path, metavar="PREVIOUS", help="after measuring, print every accuracy "
                        "figure beside PREVIOUS's (an earlier run's JSON) with its change (benchmarks.compare)")
    parser.add_argument("--update", action="store_true", help="measure the SECTIONs named and put them in place "
                        "of theirs in the JSON (each with its own run's header); the other sections are kept")
    args = parser.parse_args(argv)
    partial = bool(args.sections) and set(args.sections) != set(SECTIONS)
    if args.update and (args.render or not args.sections):
        parser.error("--update measures the SECTIONs it is given: name at least one, without --render")
    if args.json is None and (args.render or args.update or not partial):
        args.json = JSON_PATH
    if args.page is None and args.json is not None:
        args.page = args.json.with_suffix(".md")
    if args.render:
        if args.sections or args.quick or args.compare:
            parser.error("--render measures nothing: it takes no SECTION, no --quick and no --compare")
        try:
            doc = json.loads(args.json.read_text())
        except (OSError, ValueError) as exc:
            print(f"benchmarks: cannot read {args.json}: {exc}", file=sys.stderr)
            return 2
        texts = current_texts(doc)
        if texts != doc:  # stored prose with stale references: brought up to date, figures untouched
            args.json.write_text(json.dumps(texts, indent=1, allow_nan=False) + "\n")
            print(f"brought the stored texts of {args.json} up to date")
        write_page(texts, args.page)
        print(f"wrote {args.page} from {args.json}")
        return 0
    # argparse checks an empty nargs="*" default against choices, so SECTION is checked here.
    unknown = [s for s in args.sections if s not in SECTIONS]
    if unknown:
        parser.error(f"unknown section(s) {', '.join(unknown)}; choose from {', '.join(SECTIONS)}")
    for path in (args.json, args.page):
        if path is not None and not path.resolve().parent.is_dir():
            parser.error(f"folder {path.resolve().parent} does not exist (for {path})")
    try:
        import cv2  # noqa: F401  (the peer; the sections import it again)
    except ImportError:
        print(f"benchmarks: OpenCV, the benchmark's peer, is not installed: {INSTALL_HINT}", file=sys.stderr)
        return 2
    earlier = previous = None
    if args.compare is not None and (earlier := _earlier_run(args.compare, "--compare")) is None:
        return 2
    if args.update and (previous := _earlier_run(args.json, "--update")) is None:
        return 2
    doc = run(args.sections or SECTIONS, args.quick, argv)
    if args.compare is not None:
        print(compare.render(earlier, clean(doc)))
    if args.update:
        doc = update(previous, doc)
    if args.json is None:
        print(f"(some sections only: {JSON_PATH.relative_to(REPO)} is left as it was; --json PATH keeps these figures)")
        return 0
    args.json.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    write_page(doc, args.page)
    print(f"wrote {args.json} and {args.page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
