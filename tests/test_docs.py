"""The documentation is true: its Python examples run, its links resolve, the README stays a
guide, the command line is documented in full, and the benchmark page is what its JSON says.

Every ```python block of README.md and docs/*.md runs on its own in a fresh interpreter from
the repository's root, as a reader would paste it. A block that reads ../shared data is
skipped when that data is absent (failed under GRAPHPOSE_REQUIRE_REAL=1, as in conftest).
"""

import glob
import json
import os
import re
import subprocess
import sys

import pytest

from benchmarks import cli as bench_cli
from benchmarks import page as bench_page
from tests.conftest import REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
README_MAX_LINES = 300
SHARED = re.compile(r"\.\./shared/[\w./*-]+")  # a path or a glob pattern of paths


def _blocks():
    """(page, line, code) of every ```python block."""
    out = []
    for page in PAGES:
        text = page.read_text()
        for match in re.finditer(r"^```python\n(.*?)^```", text, re.DOTALL | re.MULTILINE):
            out.append((page, text[: match.start()].count("\n") + 1, match.group(1)))
    return out


BLOCKS = _blocks()


def _name(block):
    page, line, _ = block
    return f"{page.relative_to(REPO)}:{line}"


def test_there_are_examples_to_run():
    assert len(BLOCKS) >= 10
    assert any(page.name == "README.md" for page, _, _ in BLOCKS)


@pytest.mark.slow  # each documented Python example in a fresh interpreter
@pytest.mark.parametrize("block", BLOCKS, ids=_name)
def test_python_example_runs_on_its_own(block):
    code = block[2]
    for path in SHARED.findall(code):
        if not glob.glob(str(REPO / path)):  # the file, or a pattern's files
            message = f"{path} is absent"
            if os.environ.get("GRAPHPOSE_REQUIRE_REAL") == "1":
                pytest.fail(f"{message} and GRAPHPOSE_REQUIRE_REAL=1")
            pytest.skip(message)
    env = dict(os.environ, MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, env=env,
                          timeout=120, check=False)
    assert done.returncode == 0, f"{_name(block)} failed:\n{done.stderr[-3000:]}"


# --- the README is a guide ---------------------------------------------------------------


def test_readme_is_short():
    lines = (REPO / "README.md").read_text().count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines; move detail into docs/"


def test_readme_has_no_timings():
    """Times belong in docs/benchmarks.md, measured; the README only links to it."""
    text = (REPO / "README.md").read_text()
    found = re.findall(r"\b\d+(?:\.\d+)?\s*(?:ms|milliseconds?|seconds?|s|µs|us)\b(?![-.\w])", text)
    assert not found, f"timings in README.md: {found}"
    assert "docs/benchmarks.md" in text


def test_readme_first_commands_are_the_documented_ones():
    """The first two shell commands: set up and run the default; set up and test (what CI runs)."""
    text = (REPO / "README.md").read_text()
    commands = re.findall(r"^```sh\n(.*?)^```", text, re.DOTALL | re.MULTILINE)[:2]
    assert commands == [
        "python3 -m venv .venv && . .venv/bin/activate && pip install -e . && python scripts/estimate.py\n",
        'python3 -m venv .venv && . .venv/bin/activate && pip install -e ".[test]" && python -m pytest -q\n',
    ]
    assert "python -m pytest -q" in (REPO / ".ci" / "run").read_text()


def _numbers_and_skeleton(text):
    """The numbers of ``text`` (value, unit of its last digit) and the text with them blanked."""
    pattern = re.compile(r"-?\d+(?:\.(\d+))?(?:e-?\d+)?")
    numbers = [(float(m.group(0)), 10.0 ** -len(m.group(1) or "")) for m in pattern.finditer(text)]
    return numbers, pattern.sub("#", text)


@pytest.mark.slow  # the README's first run in a subprocess
def test_readme_first_run_output_is_what_the_first_run_prints():
    """The README's sample is the first image's report: the same lines, the same numbers up to
    the last digit or two (a detector tweak moves the fifth decimal) or 20 % of a small figure."""
    readme = (REPO / "README.md").read_text()
    sample = re.search(r"^```text\n(.*?)^```", readme, re.DOTALL | re.MULTILINE).group(1)
    done = subprocess.run([sys.executable, "scripts/estimate.py"], cwd=REPO, capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    printed = done.stdout[: len(done.stdout.split("\n\n")[0]) + 1]
    (shown, shown_skeleton), (real, real_skeleton) = _numbers_and_skeleton(sample), _numbers_and_skeleton(printed)
    assert shown_skeleton == real_skeleton
    for (a, unit), (b, _) in zip(shown, real):
        assert abs(a - b) <= max(2.5 * unit, 0.2 * abs(b)), f"README shows {a}, the run prints {b}:\n{printed}"


def _local_links(page):
    """Targets of the page's relative markdown links (no scheme, anchors dropped)."""
    targets = re.findall(r"\]\(([^)\s]+)\)", page.read_text())
    return [t.split("#")[0] for t in targets if not re.match(r"^[a-z]+:", t) and not t.startswith("#")]


def test_readme_links_to_docs_pages_that_exist():
    links = [t for t in _local_links(REPO / "README.md") if t.startswith("docs/")]
    assert {"docs/index.md", "docs/conventions.md", "docs/cli.md", "docs/benchmarks.md"} <= set(links)
    missing = [t for t in links if not (REPO / t).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_local_links_resolve(page):
    missing = [t for t in _local_links(page) if t and not (page.parent / t).exists()]
    assert not missing, f"{page.relative_to(REPO)} links to missing files: {missing}"


# --- the command line is documented in full ------------------------------------------------


def _docs_text():
    return "\n".join(p.read_text() for p in PAGES)


def test_every_subcommand_and_option_is_documented():
    import argparse

    from graphpose.cli import build_parser

    parser = build_parser()
    text = _docs_text()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    seen = set()
    for name, sub in action.choices.items():
        if id(sub) in seen:  # an alias
            continue
        seen.add(id(sub))
        assert f"graphpose {name}" in text, f"subcommand {name} is not documented in docs/"
        for option in sub._actions:
            for string in option.option_strings:
                if string.startswith("--") and string != "--help":
                    assert f"`{string}" in text, f"graphpose {name} {string} is not documented in docs/"


def test_json_record_keys_are_those_of_records_docstring():
    """docs/cli.md's pose-block table has every key of graphpose/io/records.py's docstring."""
    from graphpose.io import records

    keys = re.findall(r"^``(\w+)``\s", records.__doc__, re.MULTILINE)
    assert keys == list(records.POSE_KEYS)
    cli = (REPO / "docs" / "cli.md").read_text()
    for key in keys:
        assert f"| `{key}` |" in cli, f"docs/cli.md does not describe the record key {key}"


# --- the benchmark page is generated -----------------------------------------------------------


def test_benchmark_page_is_rendered_from_its_json():
    doc = json.loads((REPO / "docs" / "benchmarks.json").read_text())
    page = (REPO / "docs" / "benchmarks.md").read_text()
    assert page == bench_page.render_page(doc), "docs/benchmarks.md was edited by hand: python -m benchmarks --render"
    assert ("Quick run" in page) == doc["quick"]
    for key in ("date", "machine", "versions", "commit"):
        assert doc[key]


def test_benchmark_page_shows_every_figure_beside_its_peer_and_goal():
    doc = {"format": 1, "quick": False, "date": "d", "python": "3", "commit": "c", "command": "python -m benchmarks",
           "machine": {"node": "n", "cpu": "c", "arch": "a", "cores": 2, "load_before": None},
           "versions": {"graphpose": "0"},
           "sections": [{"name": "pose", "seconds": 1.0, "goal": "Why.",
                         "figures": [{"figure": "GN", "unit": "ms", "fmt": ".2f", "graphpose": 0.5, "peer_name": "LM",
                                      "peer": 0.25, "ratio": 2.0, "goal": "< 1 ms", "met": True},
                                     {"figure": "NEES", "unit": "", "fmt": ".2f", "graphpose": None, "peer_name": None,
                                      "peer": None, "ratio": None, "goal": "4.5-7.5", "met": False}],
                         "blocks": [{"title": "T", "text": "x {a:.1f} {b:.2f}", "values": {"a": 1.25, "b": None},
                                     "columns": ["a", "b"], "formats": [".1f", ""], "rows": [[2.25, None]]}]}]}
    page = bench_page.render_page(doc)
    assert "| pose | GN | 0.50 ms | LM: 0.25 ms | 2.00 | < 1 ms | yes |" in page
    assert "| pose | NEES | n/a |  |  | 4.5-7.5 | no |" in page
    assert "x 1.2 n/a" in page and "| 2.2 | n/a |" in page
    assert "Quick run" not in page


def test_benchmark_without_opencv_says_how_to_install_it():
    code = ("import runpy, sys; sys.modules['cv2'] = None; sys.argv = ['benchmarks', '--quick']; "
            "runpy.run_module('benchmarks', run_name='__main__', alter_sys=True)")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60,
                          check=False)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and 'pip install -e ".[bench]"' in done.stderr
    assert "Traceback" not in done.stderr


def test_benchmark_update_replaces_only_the_sections_measured_and_says_when():
    base = {"format": 1, "quick": False, "date": "d0", "python": "3", "commit": "c0", "command": "python -m benchmarks",
            "machine": {"node": "n", "cpu": "c", "arch": "a", "cores": 2, "load_before": None},
            "versions": {"graphpose": "0"}}
    old = {**base, "sections": [{"name": n, "seconds": 1.0, "goal": f"old {n}", "figures": [], "blocks": []}
                                for n in ("junctions", "pose")]}
    new = {**base, "date": "d1", "commit": "c1", "command": "python -m benchmarks pose noise --update",
           "sections": [{"name": n, "seconds": 2.0, "goal": f"new {n}", "figures": [], "blocks": []}
                        for n in ("pose", "noise")]}
    doc = bench_cli.update(old, new)
    rank = {n: i for i, n in enumerate(bench_cli.SECTIONS)}
    expected = sorted(["junctions", "pose", "noise"], key=lambda n: rank.get(n, len(rank)))  # SECTIONS' order
    assert [s["name"] for s in doc["sections"]] == expected
    goals = {s["name"]: s["goal"] for s in doc["sections"]}
    assert goals == {"junctions": "old junctions", "pose": "new pose", "noise": "new noise"}
    assert doc["date"] == "d0" and doc["commit"] == "c0"  # the document's own run is the full one
    runs = {s["name"]: s.get("run") for s in doc["sections"]}
    assert runs["junctions"] is None and runs["pose"]["commit"] == "c1"
    page = bench_page.render_page(doc)
    assert page.count("Measured in a run of its own: d1, commit c1") == 2
