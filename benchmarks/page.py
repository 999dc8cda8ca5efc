"""The benchmark's page: ``docs/benchmarks.md`` rendered from the JSON document (the only renderer).

Every section's figures and blocks (the layout in :mod:`benchmarks`) become markdown here, and
only here: :func:`render_page` for the page, :func:`render_section` for one section as a run
prints it, :func:`table` for any table.
"""

from __future__ import annotations

import re
import string
from pathlib import Path

#: Texts a run stored before the sections' texts dropped them, as the page now reads them: the
#: tracker's issue numbers (the tracker is not in the repository; history lives in git and
#: CHANGELOG.md) and the benchmark's former script name. ``python -m benchmarks --render`` brings
#: the JSON's stored prose up to date the same way (:func:`current_texts`; figures are never
#: touched), and the next run of a section stores its module's present text.
_STALE = ((re.compile(r" \(the map before issues? \d+\)"), ""),
          (re.compile(r"; issues? \d+'s figures?\)"), ")"),
          (re.compile(r" \(issues? \d+\)"), ""),
          (re.compile(r"python scripts/bench\.py"), "python -m benchmarks"))


def current(text: str) -> str:
    """``text`` (markdown of stored texts) without the stale references of :data:`_STALE`."""
    for pattern, replacement in _STALE:
        text = pattern.sub(replacement, text)
    return text


def current_texts(doc):
    """``doc`` (a run's JSON, parsed) with :func:`current` applied to every string in it: the
    stored prose brought up to date; numbers, and so every figure, are left as they are."""
    if isinstance(doc, str):
        return current(doc)
    if isinstance(doc, list):
        return [current_texts(v) for v in doc]
    if isinstance(doc, dict):
        return {k: current_texts(v) for k, v in doc.items()}
    return doc


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


def table(columns, formats, rows) -> str:
    """A markdown table: ``columns``, a format spec per column (missing ones: plain), ``rows`` of cells."""
    formats = list(formats or []) + [""] * (len(columns) - len(formats or []))
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(cell(v, f) for v, f in zip(row, formats)) + " |")
    return "\n".join(lines)


def _with_unit(value, figure) -> str:
    text = cell(value, figure.get("fmt", ""))
    return f"{text} {figure['unit']}" if value is not None and figure.get("unit") else text


def summarytable(sections) -> str:
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
            parts.append(table(block["columns"], block.get("formats"), block.get("rows", [])))
    parts.append(f"*Section time: {section['seconds']:.0f} s.*")
    if section.get("run"):
        r = section["run"]
        quick = " (quick)" if r.get("quick") else ""
        parts.append(f"*Measured in a run of its own{quick}: {r['date']}, commit {r['commit']}, `{r['command']}`; "
                     f"versions {', '.join(f'{k} {v}' for k, v in r['versions'].items())}.*")
    return current("\n\n".join(parts) + "\n")


def render_page(doc) -> str:
    """``docs/benchmarks.md`` from the JSON document ``doc`` (the only way the page is made)."""
    m = doc["machine"]
    load = "n/a" if m.get("load_before") is None else " ".join(f"{x:.2f}" for x in m["load_before"])
    names = ", ".join(f"{s['name']} ({s['seconds']:.0f} s{', own run' if s.get('run') else ''})"
                      for s in doc["sections"])
    parts = [
        "# Benchmarks",
        ("<!-- Generated by python -m benchmarks from docs/benchmarks.json: do not edit. Measure again with "
         "`python -m benchmarks`, or redraw this page from the JSON with `python -m benchmarks --render`. -->"),
    ]
    if doc["quick"]:
        parts.append("> **Quick run** (`--quick`): fewer images, frames and repeats than the full benchmark. "
                     "It shows that the benchmark runs, not the figures of record; run "
                     "`python -m benchmarks` for those.")
    parts += [
        ("graphpose beside its peer, OpenCV, on the same images in the same run. Every figure below was "
         "measured by `python -m benchmarks` and written to [benchmarks.json](benchmarks.json); ratios are "
         "graphpose / OpenCV (below 1: graphpose is lower, i.e. more accurate or faster). Wall times depend "
         "on the machine and its load (on a shared 2-core machine they vary by about 25 % between runs); "
         "accuracy figures do not. The tests check correctness only, never time."),
        table(["run", ""], [], [
            ["date", doc["date"]],
            ["machine", f"{m['node']}: {m['cpu']} ({m['arch']}), {m['cores']} cores; load average before the run {load}"],
            ["Python", doc["python"]],
            ["versions", ", ".join(f"{k} {v}" for k, v in doc["versions"].items())],
            ["commit", doc["commit"]],
            ["command", f"`{doc['command']}`"],
            ["sections", names],
        ]),
        "## Summary",
        summarytable(doc["sections"]),
    ]
    page = current("\n\n".join(parts) + "\n")
    return page + "".join("\n" + render_section(s) for s in doc["sections"])


def write_page(doc, page_path) -> None:
    Path(page_path).write_text(render_page(doc))
