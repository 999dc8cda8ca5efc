"""The benchmark is a package run with ``python -m benchmarks``: no path set up by hand, one
module a section, and the comparison of two runs flags what moved.

The figures themselves are the benchmark's to measure (never a test's); these tests check its
plumbing only, on small hand-made documents.
"""

import ast
import importlib
import json
import re
import subprocess
import sys

import numpy as np
import pytest

from benchmarks import cli, compare
from benchmarks.long_track import ping_pong
from tests.conftest import REPO


def _figure(name, value, unit="px", peer=None):
    return {"figure": name, "unit": unit, "fmt": ".3f", "graphpose": value, "peer_name": None if peer is None else "P",
            "peer": peer, "ratio": None, "goal": "", "met": None}


def _doc(*figures):
    return {"sections": [{"name": "pose", "figures": list(figures), "blocks": []}]}


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_benchmark_sets_up_no_path_by_hand():
    for path in sorted((REPO / "benchmarks").glob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr == "path" and getattr(node.value, "id", None) == "sys":
                pytest.fail(f"{path.name}:{node.lineno} touches sys.path")
            if isinstance(node, ast.ImportFrom) and node.module == "sys" and any(a.name == "path" for a in node.names):
                pytest.fail(f"{path.name}:{node.lineno} imports sys.path")


def test_scripts_keep_only_the_example_and_the_data_maker():
    assert sorted(p.name for p in (REPO / "scripts").glob("*.py")) == ["estimate.py", "make_data.py"]


def test_every_section_is_a_module_with_main():
    for name in cli.SECTIONS:
        module = importlib.import_module(f"benchmarks.{name}")
        assert callable(module.main), name


def test_compare_flags_an_accuracy_figure_that_moved_and_leaves_timings_out():
    old = _doc(_figure("pose error", 1.0, peer=2.0), _figure("junction error", 0.5),
               _figure("solve time", 1.0, unit="ms"), _figure("NEES mean", 6.0, unit=""), _figure("gone", 3.0))
    new = _doc(_figure("pose error", 1.005, peer=2.0), _figure("junction error", 0.52),
               _figure("solve time", 9.0, unit="ms"), _figure("NEES mean", 6.0001, unit=""))
    rows = {(r[1], r[2]): r for r in compare.compare(old, new)}
    assert ("solve time", "graphpose") not in rows
    assert rows["pose error", "graphpose"][-1] == "" and rows["pose error", "P"][5] == 0.0
    assert rows["junction error", "graphpose"][-1].startswith("moved")
    assert rows["NEES mean", "graphpose"][-1] == "NEES changed"  # any change of a NEES
    assert rows["gone", "graphpose"][-1] == "only in the old run"
    assert "5 accuracy figures" in compare.render(old, new)


def test_compare_command_exit_codes(tmp_path):
    same = tmp_path / "a.json"
    same.write_text(json.dumps(_doc(_figure("pose error", 1.0))))
    run = [sys.executable, "-m", "benchmarks.compare", str(same)]
    done = subprocess.run([*run, str(same)], cwd=REPO, capture_output=True, text=True, check=False)
    assert done.returncode == 0 and "0 flagged" in done.stdout
    done = subprocess.run([*run, str(tmp_path / "missing.json")], cwd=REPO, capture_output=True, text=True,
                          check=False)
    assert done.returncode == 2 and "cannot read" in done.stderr and "Traceback" not in done.stderr


def test_the_long_run_plays_its_frames_forward_and_back():
    order = ping_pong(4, 11)
    np.testing.assert_array_equal(order, [0, 1, 2, 3, 2, 1, 0, 1, 2, 3, 2])
    assert np.all(np.abs(np.diff(order)) == 1)  # continuous: no jump back to the first frame


def test_the_page_is_drawn_from_the_json_without_tracker_numbers():
    # docs/benchmarks.md is what `python -m benchmarks --render` draws from the stored JSON; the
    # stored texts of earlier runs name tracker issues, which the page leaves out.
    from benchmarks.page import current, render_page

    doc = json.loads((REPO / "docs" / "benchmarks.json").read_text())
    page = render_page(doc)
    assert not re.search(r"issues? \d", page)
    assert "scripts/bench.py" not in page
    assert current("Goals (issue 27): at most 1.3x (mrcal's 0.020; issue 30's figure)") == (
        "Goals: at most 1.3x (mrcal's 0.020)")


def test_render_brings_the_stored_texts_up_to_date_and_leaves_every_figure(tmp_path):
    # --render rewrites the JSON's stale prose (benchmarks.page.current_texts), never a number.
    doc = json.loads((REPO / "docs" / "benchmarks.json").read_text())
    section = doc["sections"][0]
    section["goal"] = "Goals (issue 27): " + section["goal"]
    section["figures"][0]["figure"] += " (issue 27)"
    path = tmp_path / "b.json"
    path.write_text(json.dumps(doc))
    assert cli.main(["--render", "--json", str(path), "--page", str(tmp_path / "b.md")]) == 0
    after = json.loads(path.read_text())
    assert after["sections"][0]["goal"] == "Goals: " + doc["sections"][0]["goal"].split(": ", 1)[1]
    assert not re.search(r"issues? \d", path.read_text() + (tmp_path / "b.md").read_text())

    def numbers(d):
        if isinstance(d, dict):
            return [x for v in d.values() for x in numbers(v)]
        if isinstance(d, list):
            return [x for v in d for x in numbers(v)]
        return [] if isinstance(d, str) else [d]

    assert numbers(after) == numbers(doc)
