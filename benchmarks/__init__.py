"""Benchmarks: graphpose beside its peer (OpenCV), medians and ratios, measured in one run.

    python -m benchmarks [SECTION ...] [--quick] [--json PATH] [--page PATH] [--compare PREVIOUS.json]
    python -m benchmarks --render [--json PATH] [--page PATH]
    python -m benchmarks SECTION ... --update [--json PATH] [--page PATH]
    python -m benchmarks.<section> [--quick]          # the same as: python -m benchmarks SECTION [--quick]
    python -m benchmarks.compare OLD.json NEW.json    # accuracy figures of two runs side by side

SECTION is any of: junctions, detect, noise, pose, lens, calibration, speed, tracking, batch,
recordings
(default: all). Each section lives in ``benchmarks/<section>.py``; its ``main(quick)`` measures
and returns its figures as a dict (below). :mod:`benchmarks.cli` adds the run's header (date,
machine, versions, commit), writes everything to ``docs/benchmarks.json`` and renders
``docs/benchmarks.md`` from that JSON with :func:`benchmarks.page.render_page` (the one
renderer), so the page is never edited by hand; ``--render`` redraws the page from the JSON
without measuring anything; ``--update`` measures the named sections again and puts them in
place of theirs in the JSON, each such section carrying the header of its own run (``"run"``:
date, machine load, versions, commit, command), which the page prints under it; ``--compare``
prints the run's accuracy figures beside an earlier run's (:mod:`benchmarks.compare`). Each
section measures graphpose and its peer side by side within itself, so a section's figures
compare within it wherever it was run; figures of sections from different runs do not. A run of
some sections only prints its figures (and writes them where ``--json`` says), so that it never
replaces the full run's. OpenCV is the peer only here: install it with
``pip install -e ".[bench]"``. Every figure is measured in the run, never typed in.

Run it from the repository's root (``python -m``, no path set up by hand). What the sections
share (paths, statistics, timing, the memory probe's readers, OpenCV's adapters) is in
:mod:`benchmarks._common`.

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
