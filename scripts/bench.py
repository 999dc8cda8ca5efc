#!/usr/bin/env python
"""Benchmarks: graphpose beside its peer (OpenCV), medians and ratios, measured in one run.

    python scripts/bench.py [SECTION ...] [--quick] [--json PATH] [--page PATH]
    python scripts/bench.py --render [--json PATH] [--page PATH]
    python scripts/bench.py SECTION ... --update [--json PATH] [--page PATH]
    python scripts/bench_<section>.py [--quick]       # the same as: bench.py SECTION [--quick]

SECTION is any of: junctions, detect, pose, lens, calibration, speed, tracking, batch (default: all). Each section lives in
``scripts/bench_<section>.py``; its ``main(quick)`` measures and returns its figures as a
dict (below). This script adds the run's header (date, machine, versions, commit), writes
everything to ``docs/benchmarks.json`` and renders ``docs/benchmarks.md`` from that JSON with
:func:`render_page`, so the page is never edited by hand; ``--render`` redraws the page from
the JSON without measuring anything; ``--update`` measures the named sections again and puts
them in place of theirs in the JSON, each such section carrying the header of its own run
(``"run"``: date, machine load, versions, commit, command), which the page prints under it. Each
section measures graphpose and its peer side by side within itself, so a section's figures
compare within it wherever it was run; figures of sections from different runs do not. A run of some sections only prints its figures (and
writes them where ``--json`` says), so that it never replaces the full run's. OpenCV is the peer only here: install it with
``pip install -e ".[bench]"``. Every figure is measured in the run, never typed in.

A section's dict::

    {"goal": "what the section measures and why (markdown)",
     "figures": [  # its headline figures, for the summary table
         {"figure": str, "unit": str, "fmt": format spec, "graphpose": number,
          "peer_name": str or None, "peer": number or None, "ratio": graphpose / peer or None,
          "goal": str, "met": bool or None}, ...],
     "blocks": [   # its detail: a table, a paragraph, or both
         {"title": str or None, "text": str.format template or None, "values": {name: number},
          "columns": [str], "formats": [format spec per column], "rows": [[cell, ...]]}, ...]}

Cells and values are numbers, strings, booleans or None (rendered "n/a"); NaN is stored as
None, since JSON has no NaN.
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
import string
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
JSON_PATH = REPO / "docs" / "benchmarks.json"
PAGE_PATH = REPO / "docs" / "benchmarks.md"
SECTIONS = ("junctions", "detect", "pose", "lens", "calibration", "speed", "tracking", "batch")
#: Version of the JSON layout described in the module docstring.
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
        "command": " ".join(["python scripts/bench.py", *map(shlex.quote, argv)]),
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
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    doc = header(argv, quick)
    doc["sections"] = []
    for name in sections:
        module = importlib.import_module(f"bench_{name}")
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


# --- the page ------------------------------------------------------------------------------


class _Formatter(string.Formatter):
    """``str.format`` that writes None (a NaN in the JSON) as "n/a" whatever the spec."""

    def format_field(self, value, format_spec):
        return "n/a" if value is None else super().format_field(value, format_spec)


def cell(value, spec="") -> str:
    """One value as text: None -> "n/a", booleans -> yes/no, numbers with ``spec``."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)) and spec:
        return format(value, spec)
    return str(value)


def _table(columns, formats, rows) -> str:
    formats = list(formats or []) + [""] * (len(columns) - len(formats or []))
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(cell(v, f) for v, f in zip(row, formats)) + " |")
    return "\n".join(lines)


def _with_unit(value, figure) -> str:
    text = cell(value, figure.get("fmt", ""))
    return f"{text} {figure['unit']}" if value is not None and figure.get("unit") else text


def summary_table(sections) -> str:
    """The headline figures of every section: graphpose, the peer, their ratio and the goal."""
    lines = ["| section | figure | graphpose | OpenCV (peer) | graphpose / peer | goal | met |",
             "|---|---|---|---|---|---|---|"]
    for section in sections:
        for f in section.get("figures", []):
            peer = "" if f.get("peer_name") is None else f"{f['peer_name']}: {_with_unit(f.get('peer'), f)}"
            ratio = "" if f.get("peer_name") is None else cell(f.get("ratio"), ".2f")
            met = "" if f.get("met") is None else cell(f["met"])
            lines.append(f"| {section['name']} | {f['figure']} | {_with_unit(f['graphpose'], f)} | {peer} | {ratio} "
                         f"| {f.get('goal') or ''} | {met} |")
    return "\n".join(lines)


def render_section(section) -> str:
    """One section as markdown: its goal, then every block (title, paragraph, table)."""
    parts = [f"## {section['name'].capitalize()}", section["goal"]]
    for block in section.get("blocks", []):
        if block.get("title"):
            parts.append(f"### {block['title']}")
        if block.get("text"):
            parts.append(_Formatter().format(block["text"], **block.get("values", {})))
        if block.get("columns"):
            parts.append(_table(block["columns"], block.get("formats"), block.get("rows", [])))
    parts.append(f"*Section time: {section['seconds']:.0f} s.*")
    if section.get("run"):
        r = section["run"]
        quick = " (quick)" if r.get("quick") else ""
        parts.append(f"*Measured in a run of its own{quick}: {r['date']}, commit {r['commit']}, `{r['command']}`; "
                     f"versions {', '.join(f'{k} {v}' for k, v in r['versions'].items())}.*")
    return "\n\n".join(parts) + "\n"


def render_page(doc) -> str:
    """``docs/benchmarks.md`` from the JSON document ``doc`` (the only way the page is made)."""
    m = doc["machine"]
    load = "n/a" if m.get("load_before") is None else " ".join(f"{x:.2f}" for x in m["load_before"])
    names = ", ".join(f"{s['name']} ({s['seconds']:.0f} s{', own run' if s.get('run') else ''})"
                      for s in doc["sections"])
    parts = [
        "# Benchmarks",
        ("<!-- Generated by scripts/bench.py from docs/benchmarks.json: do not edit. Measure again with "
         "`python scripts/bench.py`, or redraw this page from the JSON with `python scripts/bench.py --render`. -->"),
    ]
    if doc["quick"]:
        parts.append("> **Quick run** (`--quick`): fewer images, frames and repeats than the full benchmark. "
                     "It shows that the benchmark runs, not the figures of record; run "
                     "`python scripts/bench.py` for those.")
    parts += [
        ("graphpose beside its peer, OpenCV, on the same images in the same run. Every figure below was "
         "measured by `scripts/bench.py` and written to [benchmarks.json](benchmarks.json); ratios are "
         "graphpose / OpenCV (below 1: graphpose is lower, i.e. more accurate or faster). Wall times depend "
         "on the machine and its load (on a shared 2-core machine they vary by about 25 % between runs); "
         "accuracy figures do not. The tests check correctness only, never time."),
        _table(["run", ""], [], [
            ["date", doc["date"]],
            ["machine", f"{m['node']}: {m['cpu']} ({m['arch']}), {m['cores']} cores; load average before the run {load}"],
            ["Python", doc["python"]],
            ["versions", ", ".join(f"{k} {v}" for k, v in doc["versions"].items())],
            ["commit", doc["commit"]],
            ["command", f"`{doc['command']}`"],
            ["sections", names],
        ]),
        "## Summary",
        summary_table(doc["sections"]),
    ]
    page = "\n\n".join(parts) + "\n"
    return page + "".join("\n" + render_section(s) for s in doc["sections"])


def write_page(doc, page_path) -> None:
    Path(page_path).write_text(render_page(doc))


# --- the command -------------------------------------------------------------------------------


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sections", nargs="*", metavar="SECTION", help=f"any of {', '.join(SECTIONS)} (default: all)")
    parser.add_argument("--quick", action="store_true", help="fewer images, frames and repeats: a smoke run")
    parser.add_argument("--json", type=Path, help="where the figures go (default docs/benchmarks.json for a run "
                        "of every section and for --render; a run of some sections writes only when given this)")
    parser.add_argument("--page", type=Path, help="the page rendered from them (default: the JSON's path "
                        "with .md, docs/benchmarks.md for docs/benchmarks.json)")
    parser.add_argument("--render", action="store_true", help="measure nothing: redraw the page from the JSON")
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
        if args.sections or args.quick:
            parser.error("--render measures nothing: it takes no SECTION and no --quick")
        try:
            doc = json.loads(args.json.read_text())
        except (OSError, ValueError) as exc:
            print(f"bench.py: cannot read {args.json}: {exc}", file=sys.stderr)
            return 2
        write_page(doc, args.page)
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
        print(f"bench.py: OpenCV, the benchmark's peer, is not installed: {INSTALL_HINT}", file=sys.stderr)
        return 2
    if args.update:
        try:
            previous = json.loads(args.json.read_text())
        except (OSError, ValueError) as exc:
            print(f"bench.py: --update needs the JSON of an earlier run; cannot read {args.json}: {exc}",
                  file=sys.stderr)
            return 2
    doc = run(args.sections or SECTIONS, args.quick, argv)
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
