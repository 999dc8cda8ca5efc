"""What a new user is told, as the user types the command (in process: ``main([...])``).

Each message says what is wrong and what to do: no default camera (estimate, track, batch),
a broken image file, the bounds rule, a board of another size, an image given as a command,
one message per lost frame, and a missing extra found before the work starts.
"""

import json
import os
import shutil

import numpy as np
import pytest

from graphpose import Board
from graphpose.cli import main
from graphpose.cli.options import NO_CAMERA
from graphpose.io.files import encode_png
from graphpose.synth.poses import loose_polygon
from graphpose.synth.render import render
from tests.batch.helpers import SIZE, half_K
from tests.conftest import REPO
from tests.helpers import PROJECT_K_OPTION as K_OPTION  # the bundled example's camera

BUNDLED = REPO / "graphpose" / "data"
#: The bundled synthetic_03.png's polygon (clockwise from junction 0's corner), as --bounds.
BOUNDS = "189.516,83.2248,434.212,168.717,377.418,363.65,111.435,276.632"


def one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# --- no default camera --------------------------------------------------------------------


@pytest.mark.parametrize("command", [
    ["estimate", str(BUNDLED / "synthetic_01.png")],
    ["estimate", str(BUNDLED / "synthetic_01.png"), "--board", "8x6x0.0635", "--json", "-"],
    ["track", str(BUNDLED / "synthetic_01.png"), str(BUNDLED / "synthetic_02.png")],
    ["batch", str(BUNDLED), "--out", "r.jsonl"],
])
def test_a_users_image_without_a_camera_is_one_line_naming_both_options_and_calibrate(command, tmp_path,
                                                                                       monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(command) == 2
    line = one_line(capsys)
    assert line == f"graphpose {command[0]}: error: {NO_CAMERA}"
    for words in ("--camera FILE", "--K FX,FY,CX,CY", "graphpose calibrate"):
        assert words in line
    assert not (tmp_path / "r.jsonl").exists()
    assert capsys.readouterr().out == ""


def test_the_bundled_example_keeps_its_own_camera(capsys):
    assert main(["estimate", "-q", "--json", "-"]) == 0  # no argument but the output's
    records = json.loads(capsys.readouterr().out)
    assert len(records) == 4 and {r["status"] for r in records} == {"ok"}
    camera = records[0]["camera"]
    assert camera["model"] == "pinhole" and camera["K"] == [[564.9, 0.0, 337.3], [0.0, 564.3, 226.5], [0, 0, 1]]
    assert camera["file"].endswith("cases.json") and records[0]["board"] == {"cols": 8, "rows": 6, "square_m": 0.0635}


def test_a_case_file_without_a_camera_takes_one_from_the_options(tmp_path, capsys):
    cases = tmp_path / "cases.json"
    cases.write_text(json.dumps({"cases": [{"image": str(BUNDLED / "synthetic_03.png")}]}))
    assert main(["estimate", "--cases", str(cases), "-q"]) == 2
    line = one_line(capsys)
    assert f"case file {cases} gives no K nor camera: no camera: give --camera FILE" in line
    assert main(["estimate", "--cases", str(cases), "--K", K_OPTION, "--json", "-"]) == 0
    (record,) = json.loads(capsys.readouterr().out)
    assert record["status"] == "ok" and record["camera"]["file"] is None  # the K given
    assert record["camera"]["K"][0] == [564.9, 0.0, 337.3]


def test_the_report_names_the_camera_and_the_board(capsys):
    assert main(["estimate", str(BUNDLED / "synthetic_03.png"), "--bounds", BOUNDS, "--K", K_OPTION]) == 0
    report = capsys.readouterr().out
    assert "  camera          --K: pinhole, fx 564.9, fy 564.3, cx 337.3, cy 226.5 px\n" in report
    assert "  board           8 x 6 junctions, 63.5 mm squares\n" in report


# --- messages that say what to do ---------------------------------------------------------


@pytest.mark.parametrize("content", [b"", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x02\x80"])
def test_an_empty_or_cut_short_png_is_not_a_readable_image_with_no_advice_to_install(content, tmp_path, capsys):
    path = tmp_path / "broken.png"
    path.write_bytes(content)
    assert main(["estimate", str(path), "--K", K_OPTION]) == 2
    line = one_line(capsys)
    assert line.startswith(f"graphpose estimate: error: cannot read image {path}: not a readable image")
    assert "truncated or corrupt" in line and "pip" not in line and "backend" not in line


def test_a_truncated_real_png_says_truncated_or_corrupt(tmp_path, capsys):
    path = tmp_path / "cut.png"
    path.write_bytes((BUNDLED / "synthetic_01.png").read_bytes()[:2000])
    assert main(["estimate", str(path), "--K", K_OPTION]) == 2
    assert one_line(capsys) == f"graphpose estimate: error: cannot read image {path}: not a readable image (truncated or corrupt)"


def _bounds_text(poly):
    return ",".join(f"{u:g},{v:g}" for u, v in np.asarray(poly, dtype=float).T)


def test_counter_clockwise_bounds_get_the_rule_as_it_is(capsys):
    values = BOUNDS.split(",")
    reverse = ",".join(",".join(values[2 * i:2 * i + 2]) for i in (3, 2, 1, 0))
    assert main(["estimate", str(BUNDLED / "synthetic_03.png"), "--bounds", reverse, "--K", K_OPTION]) == 2
    line = one_line(capsys)
    assert ("bounds must run clockwise (in the image, v down), starting at the corner nearest junction 0; "
            "these corners run counter-clockwise") in line
    assert "upper-left vertex" not in line


def test_a_self_intersecting_polygon_is_named_as_such(capsys):
    values = BOUNDS.split(",")
    crossed = ",".join(",".join(values[2 * i:2 * i + 2]) for i in (0, 1, 3, 2))  # two corners swapped
    assert main(["estimate", str(BUNDLED / "synthetic_03.png"), "--bounds", crossed, "--K", K_OPTION]) == 2
    line = one_line(capsys)
    assert "bounds is a self-intersecting polygon (two of its edges cross)" in line
    assert "clockwise, starting at the corner nearest junction 0" in line


def test_a_board_of_another_size_names_the_default_and_how_to_give_the_board(tmp_path, capsys):
    K, board = half_K(), Board(9, 6, 0.02)
    T = np.eye(4)
    T[:3, 3] = [0.08, 0.05, -0.35]  # facing the board's middle from 35 cm
    rendering = render(K, T, board, SIZE, rng=np.random.default_rng(3))
    path = tmp_path / "nine_by_six.png"
    path.write_bytes(encode_png(rendering.image))
    k = f"{K[0, 0]},{K[1, 1]},{K[0, 2]},{K[1, 2]}"
    assert main(["estimate", str(path), "--K", k, "--bounds", _bounds_text(loose_polygon(rendering, rng=3))]) == 1
    line = one_line(capsys)
    assert "found a 9 x 6 board of junctions; the board spec says 8 x 6" in line, line
    assert "the default board is 8x6x0.0635; give yours with --board COLSxROWSxSQUARE_M" in line
    assert main(["estimate", str(path), "--K", k, "--board", "8x6x0.02", "-q"]) == 1  # a wrong spec given
    line = one_line(capsys)
    assert "the board spec says 8 x 6 (check --board COLSxROWSxSQUARE_M" in line, line
    assert "default board" not in line
    assert main(["estimate", str(path), "--K", k, "--board", "9x6x0.02", "-q"]) == 0  # as told


@pytest.mark.parametrize("first", [str(BUNDLED / "synthetic_01.png"), "board.jpg", str(BUNDLED)])
def test_an_image_given_as_the_command_points_to_graphpose_estimate(first, capsys):
    assert main([first]) == 2
    line = one_line(capsys)
    assert line == (f"graphpose: error: '{first}' is not a command; for the camera pose in an image or a folder of "
                    f"images, run: graphpose estimate {first} --camera FILE (or --K FX,FY,CX,CY)")


def test_a_misspelt_command_is_still_argparses_invalid_choice(capsys):
    assert main(["estmate"]) == 2
    assert "invalid choice: 'estmate'" in one_line(capsys)


@pytest.mark.slow  # tracks rendered frames through the CLI
def test_a_lost_frame_has_one_message_not_the_same_words_per_search_area(tmp_path, capsys):
    seq = tmp_path / "seq"
    assert main(["render-sequence", str(seq), "--frames", "6", "--excursions", "0", "--seed", "1", "-q"]) == 0
    frames = tmp_path / "frames"
    frames.mkdir()
    for path in sorted(seq.glob("frame_*.png")):
        shutil.copy(path, frames / path.name)
    grey = np.full((480, 640), 128, np.uint8)
    (frames / "frame_00003.png").write_bytes(encode_png(grey))  # no board: every search area fails
    bounds = json.loads((seq / "bounds.json").read_text())["bounds"]
    out = tmp_path / "track.json"
    assert main(["track", str(frames), "--K", K_OPTION, "--bounds", _bounds_text(bounds), "--json", str(out),
                 "-q"]) == 0
    lost = json.loads(out.read_text())["frames"][3]
    assert lost["status"] == "lost"
    message = lost["message"]
    assert message.count("extraction failed") == 1, message
    parts = message.split("; ")
    assert len(parts) == len(set(parts)), message  # each reason once
    assert "search areas" in message


# --- extras checked before the work starts ------------------------------------------------


def test_track_plot_without_matplotlib_fails_before_tracking(monkeypatch, tmp_path, capsys):
    import sys

    import graphpose.track.tracker as tracker

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    monkeypatch.setattr(tracker, "track_sequence", lambda *a, **k: pytest.fail("tracked before the check"))
    frames = [str(BUNDLED / "synthetic_01.png"), str(BUNDLED / "synthetic_02.png")]
    assert main(["track", *frames, "--K", K_OPTION, "--plot", str(tmp_path / "t.png")]) == 2
    line = one_line(capsys)
    assert line.startswith("graphpose track: error: graphpose track --plot needs matplotlib (the plot extra): pip install")
    assert not (tmp_path / "t.png").exists()


def test_case_file_paths_keep_their_symbolic_links(tmp_path, capsys, monkeypatch):
    os.symlink(BUNDLED, tmp_path / "linked")
    (tmp_path / "cases.json").write_text(json.dumps({"K": [[564.9, 0, 337.3], [0, 564.3, 226.5], [0, 0, 1]],
                                                     "cases": [{"image": "linked/synthetic_03.png"}]}))
    monkeypatch.chdir(tmp_path)
    assert main(["estimate", "--cases", "cases.json", "--json", "-"]) == 0
    (record,) = json.loads(capsys.readouterr().out)
    assert record["image"] == str(tmp_path / "linked" / "synthetic_03.png")  # not .../graphpose/data/...
