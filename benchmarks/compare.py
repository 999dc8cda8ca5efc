"""Two runs of the benchmark side by side: every accuracy figure, its relative change, and what moved.

    python -m benchmarks.compare OLD.json NEW.json
    python -m benchmarks SECTION ... --json NEW.json --compare OLD.json    # the same, after a run

Figures are the sections' headline figures (graphpose's and the peer's value), matched by
section and name. Timings and resources (a unit of ms, s or MB, or a name about time, speed,
memory or overhead) differ between runs by the machine's load and are left out. A figure is
flagged when it moved by more than 1 % (:data:`TOLERANCE`), a NEES figure when it moved at all,
and a figure that only one run has is listed as such. Exit status 0 when nothing is flagged,
1 otherwise, 2 when a file cannot be read.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from benchmarks.page import table

#: Relative change beyond which an accuracy figure is flagged.
TOLERANCE = 0.01
#: Units and words of a figure that make it a timing or a resource, not an accuracy figure.
TIMING_UNITS = ("ms", "s", "MB")
TIMING_WORDS = ("time", "speed", "per second", "overhead", "memory", "exponent", "back end", "back-end",
                "per frame")


def is_timing(figure: dict) -> bool:
    """Whether a headline figure measures time or resources (left out of the comparison)."""
    name = figure["figure"].lower()
    return figure.get("unit") in TIMING_UNITS or any(word in name for word in TIMING_WORDS)


def accuracy_figures(doc: dict) -> dict:
    """{(section, figure name, "graphpose" or the peer's name): (value, format spec)} of a run."""
    out = {}
    for section in doc["sections"]:
        for f in section.get("figures", []):
            if is_timing(f):
                continue
            out[section["name"], f["figure"], "graphpose"] = (f["graphpose"], f.get("fmt", ""))
            if f.get("peer_name") is not None:
                out[section["name"], f["figure"], f["peer_name"]] = (f.get("peer"), f.get("fmt", ""))
    return out


def change(old, new):
    """Relative change of ``new`` from ``old`` (0 where both are equal, inf from 0, None where
    either is absent or not a number)."""
    if not isinstance(old, (int, float)) or not isinstance(new, (int, float)) or isinstance(old, bool):
        return None if old != new else 0.0
    if old == new:
        return 0.0
    return (new - old) / abs(old) if old != 0 else math.inf


def compare(old: dict, new: dict) -> list:
    """Rows [section, figure, of, old, new, relative change, flag] over both runs' figures."""
    a, b = accuracy_figures(old), accuracy_figures(new)
    rows = []
    for key in [*a, *(k for k in b if k not in a)]:
        section, name, who = key
        if key not in a or key not in b:
            rows.append([section, name, who, a.get(key, (None,))[0], b.get(key, (None,))[0], None,
                         "only in the old run" if key in a else "only in the new run"])
            continue
        (x, fmt), (y, _) = a[key], b[key]
        rel = change(x, y)
        nees = "nees" in name.lower()
        if rel is None:
            flag = "changed" if x != y else ""
        elif nees and rel != 0.0:
            flag = "NEES changed"
        elif abs(rel) > TOLERANCE:
            flag = f"moved > {100 * TOLERANCE:g} %"
        else:
            flag = ""
        rows.append([section, name, who, _text(x, fmt), _text(y, fmt), rel, flag])
    return rows


def _text(value, fmt):
    if isinstance(value, (int, float)) and not isinstance(value, bool) and fmt:
        return format(value, fmt)
    return value


def render(old: dict, new: dict) -> str:
    """The comparison as a markdown table, with a line that counts what was flagged."""
    rows = compare(old, new)
    flagged = [r for r in rows if r[-1]]
    shown = [[*r[:5], None if r[5] is None else 100 * r[5], r[6]] for r in rows]
    head = (f"{len(rows)} accuracy figures (timings left out): {len(flagged)} flagged "
            f"(moved > {100 * TOLERANCE:g} %, a NEES that moved at all, or in one run only).")
    return head + "\n\n" + table(["section", "figure", "of", "old", "new", "change %", "flag"],
                                 ["", "", "", "", "", "+.3f", ""], shown)


def read(path) -> dict:
    return json.loads(Path(path).read_text())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.compare", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("old", type=Path, help="the earlier run's JSON")
    parser.add_argument("new", type=Path, help="the later run's JSON")
    args = parser.parse_args(argv)
    try:
        old, new = read(args.old), read(args.new)
    except (OSError, ValueError) as exc:
        print(f"benchmarks.compare: cannot read a run: {exc}", file=sys.stderr)
        return 2
    print(render(old, new))
    return 1 if any(r[-1] for r in compare(old, new)) else 0


if __name__ == "__main__":
    sys.exit(main())
