"""The figures the documentation prints are the benchmark's (issue 26): each one below is read
from docs/benchmarks.json, formatted as the page prints it, and must be on the page. A new
benchmark run (`python -m benchmarks SECTION --update`) that moves a figure fails here until
the page says the new one."""

import json

import pytest

from tests.conftest import REPO

DOC = json.loads((REPO / "docs" / "benchmarks.json").read_text())


def figure(section, name, key="graphpose"):
    (s,) = [s for s in DOC["sections"] if s["name"] == section]
    (f,) = [f for f in s["figures"] if f["figure"] == name]
    return f[key]


def value(section, title, key):
    (s,) = [s for s in DOC["sections"] if s["name"] == section]
    (b,) = [b for b in s["blocks"] if b["title"].startswith(title)]
    return b["values"][key]


def row(section, title, parameter, column):
    (s,) = [s for s in DOC["sections"] if s["name"] == section]
    (b,) = [b for b in s["blocks"] if b["title"].startswith(title)]
    (r,) = [r for r in b["rows"] if r[0] == parameter]
    return r[b["columns"].index(column)]


CAL = "calibration"
LEFT, RIGHT = "OpenCV samples, left", "OpenCV samples, right"
#: (page, the printed text with {} where the figure goes, format, the figure).
FIGURES = [
    ("calibration.md", "within {} sigmas of the truth (radtan", ".2f",
     lambda: figure(CAL, "radtan: largest |parameter error| / reported sigma")),
    ("calibration.md", "\n{} (fisheye, 30 views)", ".2f", lambda: figure(CAL, "fisheye: largest |parameter error| / reported sigma")),
    ("calibration.md", "has mean {} (9 if", ".2f",
     lambda: figure(CAL, "radtan: parameter NEES mean over the same sets (9 parameters)")),
    ("calibration.md", "the fisheye's 8 parameters {})", ".2f",
     lambda: figure(CAL, "fisheye: parameter NEES mean over the same sets (8 parameters)")),
    ("calibration.md", "= {} (left)", ".1f", lambda: value(CAL, LEFT, "m")),
    ("calibration.md", "and {} (right)", ".1f", lambda: value(CAL, RIGHT, "m")),
    ("calibration.md", "has NEES {}\nover", ".2f", lambda: value(CAL, "The pose with the calibration", "full")),
    ("calibration.md", "over {} trials", "d", lambda: value(CAL, "The pose with the calibration", "trials")),
    ("calibration.md", "({} failed)", "d", lambda: value(CAL, "The pose with the calibration", "failed")),
    ("calibration.md", "against {} with the pixel", ",.0f", lambda: value(CAL, "The pose with the calibration", "pixel")),
    ("calibration.md", "is\n{} px (radtan)", ".3f", lambda: figure(CAL, "radtan: projection error vs the true camera at the observed junctions")),
    ("calibration.md", "and {} px (fisheye)", ".4f", lambda: figure(CAL, "fisheye: projection error vs the true camera at the observed junctions")),
    ("calibration.md", "against OpenCV's {} and", ".3f", lambda: figure(CAL, "radtan: projection error vs the true camera at the observed junctions", "peer")),
    ("calibration.md", "and {} px on its own", ".3f", lambda: figure(CAL, "fisheye: projection error vs the true camera at the observed junctions", "peer")),
    ("calibration.md", "corners ({}x and", ".2f", lambda: figure(CAL, "radtan: projection error vs the true camera at the observed junctions", "ratio")),
    ("calibration.md", "and {}x). The", ".2f", lambda: figure(CAL, "fisheye: projection error vs the true camera at the observed junctions", "ratio")),
    ("calibration.md", "took {} s against", ".2f", lambda: value(CAL, "Speed", "g")),
    ("calibration.md", "`calibrateCamera` {} s (", ".2f", lambda: value(CAL, "Speed", "o")),
    ("calibration.md", "{} of 13 images used, RMS", "d", lambda: value(CAL, LEFT, "gu")),
    ("calibration.md", "used, RMS {} px", ".3f", lambda: value(CAL, LEFT, "g")),
    ("calibration.md", "`calibrateCamera`'s\n{} px", ".3f", lambda: value(CAL, LEFT, "o")),
    ("calibration.md", "`fx = {} +-", ".2f", lambda: row(CAL, LEFT, "fx", "graphpose")),
    ("calibration.md", "`cx = {} +-", ".2f", lambda: row(CAL, LEFT, "cx", "graphpose")),
    ("calibration.md", "`k1 = {} +-", ".4f", lambda: row(CAL, LEFT, "k1", "graphpose")),
    ("calibration.md", "`k3 = {} +-", ".2f", lambda: row(CAL, LEFT, "k3", "graphpose")),
    ("calibration.md", "comes out at\n{} +-", ".2f", lambda: row(CAL, RIGHT, "fx", "graphpose")),
]


@pytest.mark.parametrize("page, text, fmt, get", FIGURES, ids=[f"{p}: {t[:30]}" for p, t, _, _ in FIGURES])
def test_a_printed_figure_is_the_benchmarks(page, text, fmt, get):
    printed = text.format(format(get(), fmt))
    assert printed in (REPO / "docs" / page).read_text(), f"docs/{page} should print {printed!r} (docs/benchmarks.json)"


def test_calibration_pages_sample_output_is_the_benchmarks_calibration():
    """docs/calibration.md's sample of `graphpose calibrate` on the 13 left images prints the
    parameters the benchmark's run found on them (the same calibration), to the digits shown."""
    text = (REPO / "docs" / "calibration.md").read_text()
    sample = text.split("radtan camera, 640 x 480 pixels, from 13 images", 1)[1].split("```", 1)[0]
    shown = {}
    for line in sample.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0] in ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"):
            shown[parts[0]] = (parts[1], parts[2])
    assert len(shown) == 9
    for name, (v, sigma) in shown.items():
        assert v == format(row(CAL, LEFT, name, "graphpose"), ".6g"), name
        assert sigma == format(row(CAL, LEFT, name, "sigma"), ".3g"), name
