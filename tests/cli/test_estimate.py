"""The command line as a user runs it (subprocesses), and the files it writes.

Every subprocess pays Python's and GTSAM's start-up (about a second), so the runs are few and
each checks several things.
"""

import argparse
import io
import json
import os
import re
import struct
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from graphpose import Board, estimate_pose, load_cases, read_camera, read_image
from graphpose.cli import main
from graphpose.cli.options import Progress, parse_bounds, parse_K, parse_positive
from graphpose.io.records import POSE_KEYS
from graphpose.io.cameras import write_camera
from graphpose.io.files import encode_png
from graphpose.estimate import pose_difference
from tests.conftest import REPO, opencv_file, real_file
from tests.helpers import PROJECT_K_OPTION as K_BUNDLED

BUNDLED = REPO / "graphpose" / "data" / "cases.json"
#: The bundled example's camera as --K (its case file's K): a user's image needs one.
KEYS = {"image", *POSE_KEYS, "converged", "iterations", "junctions", "trusted", "cross_check", "orientation_ambiguous",
        "junction0_square"}


def graphpose(*args, cwd=None):
    """Run ``python -m graphpose ARGS``; returns the CompletedProcess (text, captured)."""
    return subprocess.run([sys.executable, "-m", "graphpose", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def png_size(path):
    """(width, height) from a PNG file's header; fails unless the file is a PNG."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def one_error_line(result, code, *fragments):
    assert result.returncode == code, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def bundled():
    if not BUNDLED.is_file():
        pytest.fail(f"the bundled example {BUNDLED} is missing")
    return load_cases(BUNDLED)


@pytest.fixture(scope="module")
def blank_png(tmp_path_factory):
    """A plain grey 640 x 480 PNG: a readable image with no board in it."""
    path = tmp_path_factory.mktemp("blank") / "blank.png"
    path.write_bytes(encode_png(np.full((480, 640), 128, np.uint8)))
    return path


# --- the default run ------------------------------------------------------------------------


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_script_without_arguments_runs_the_bundled_example(bundled):
    result = subprocess.run([sys.executable, str(REPO / "scripts" / "estimate.py")], cwd=REPO,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    out = result.stdout
    for case in bundled.cases:
        assert case.image.name in out
    for label in ("T_WC", "position (m)", "1-sigma (mm)", "angles (deg)", "1-sigma (deg)",
                  "px RMS", "GN vs GTSAM", "converged"):
        assert out.count(label) >= len(bundled.cases), label
    assert "NOT converged" not in out and "DISAGREE" not in out
    assert f"{len(bundled.cases)} images: {len(bundled.cases)} estimated, 0 failed" in out
    # The synthetic images know their true pose: the printed error against it is small.
    errors = re.findall(r"error vs truth\s+([\d.]+) mm, ([\d.]+) deg", out)
    assert len(errors) == len(bundled.cases)
    for mm, deg in errors:
        assert float(mm) < 1.5 and float(deg) < 0.05  # regression guard (an earlier run): at most 0.32 mm and 0.014 deg


@pytest.mark.slow  # the command in fresh processes over a folder
def test_module_json_and_overlay_folder(bundled, tmp_path):
    out_json, folder = tmp_path / "out.json", tmp_path / "overlays"
    result = graphpose("estimate", "--cases", BUNDLED, "--json", out_json, "--overlay", f"{folder}/", "-q")
    assert result.returncode == 0, result.stderr
    assert result.stdout == "" and result.stderr == ""
    records = json.loads(out_json.read_text())
    assert len(records) == len(bundled.cases)
    for record, case in zip(records, bundled.cases):
        assert KEYS <= set(record)
        assert record["image"] == str(case.image) and record["message"] is None and record["converged"]
        T = np.array(record["T_WC"])
        assert T.shape == (4, 4)
        metres, degrees = pose_difference(T, case.true_T_WC)
        assert metres < 1.5e-3 and degrees < 0.05  # regression guard (an earlier run): at most 0.32 mm and 0.014 deg
        np.testing.assert_allclose(record["xyz_m"], T[:3, 3])
        assert len(record["rpy_deg"]) == 3 and len(record["sigma_xyz_m"]) == 3
        assert all(s > 0 for s in record["sigma_xyz_m"] + record["sigma_rpy_deg"])
        n = len(record["trusted"])
        assert np.array(record["junctions"]).shape == (2, n) and n == bundled.board.n
        assert all(isinstance(t, bool) for t in record["trusted"])
        assert set(record["cross_check"]) == {"translation_m", "rotation_deg", "agree"}
        assert record["vs_truth"]["translation_mm"] == pytest.approx(1000 * metres, abs=1e-6)
        assert png_size(folder / f"{case.image.stem}.overlay.png") == (640, 480)
    assert not list(tmp_path.glob(".*.tmp")) and not list(folder.glob(".*.tmp"))


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_real_cases_target_01_matches_its_reference(tmp_path):
    cases_file = real_file("cases.json")
    result = graphpose("estimate", "--cases", cases_file, "--json", tmp_path / "real.json", "-q")
    assert result.returncode == 0, result.stderr
    records = json.loads((tmp_path / "real.json").read_text())
    cases = load_cases(cases_file).cases
    assert len(records) == 6 and all(r["converged"] and r["message"] is None for r in records)
    first = next(r for r in records if r["image"].endswith("target_01.png"))
    metres, degrees = pose_difference(np.asarray(first["T_WC"]), cases[0].ref_T_WC)
    assert metres < 0.01 and degrees < 0.5  # the goal
    assert metres < 0.005 and degrees < 0.4  # regression guard (an earlier run): 3.2 mm and 0.30 deg
    assert first["vs_reference"]["translation_mm"] == pytest.approx(1000 * metres, abs=1e-6)


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_readme_robust_run_on_the_real_cases_estimates_all_six(tmp_path):
    # `graphpose estimate --cases ../shared/data/rob501/cases.json --no-guess --robust` once
    # failed 5 of 6 images: GTSAM's robust polish stopped just above its threshold.
    result = graphpose("estimate", "--cases", real_file("cases.json"), "--no-guess", "--robust",
                       "--json", tmp_path / "robust.json")
    assert result.returncode == 0, result.stderr
    assert "6 images: 6 estimated, 0 failed" in result.stdout and "DISAGREE" not in result.stdout
    records = json.loads((tmp_path / "robust.json").read_text())
    assert all(r["status"] == "ok" and r["cross_check"]["agree"] for r in records)


@pytest.mark.slow  # the command in fresh processes
def test_one_image_with_options_guess_overlay_and_json(bundled, tmp_path):
    case = bundled.cases[0]
    guess = tmp_path / "guess.json"
    guess.write_text(json.dumps({"T_WC": case.guess_T_WC.tolist()}))
    bounds = ",".join(f"{u:g},{v:g}" for u, v in case.bounds.T)
    K = bundled.K
    overlay, out_json = tmp_path / "pose.png", tmp_path / "pose.json"
    result = graphpose("estimate", case.image, "--bounds", bounds,
                       "--K", f"{K[0, 0]},{K[1, 1]},{K[0, 2]},{K[1, 2]}", "--board", "8x6x0.0635",
                       "--guess", guess, "--overlay", overlay, "--json", out_json)
    assert result.returncode == 0, result.stderr
    assert f"{case.image}  (converged" in result.stdout
    (record,) = json.loads(out_json.read_text())
    assert record["image"] == str(case.image)
    metres, degrees = pose_difference(np.asarray(record["T_WC"]), case.true_T_WC)
    assert metres < 1.5e-3 and degrees < 0.05  # regression guard (an earlier run): at most 0.32 mm and 0.014 deg
    assert png_size(overlay) == (640, 480)


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_json_to_stdout(bundled):
    case = bundled.cases[1]
    bounds = ",".join(f"{u:g},{v:g}" for u, v in case.bounds.T)
    result = graphpose("estimate", case.image, "--bounds", bounds, "--K", K_BUNDLED, "--json", "-")
    assert result.returncode == 0, result.stderr
    (record,) = json.loads(result.stdout)
    assert KEYS <= set(record) and record["converged"]


# --- errors: one line on stderr and the exit code -----------------------------------------


BOUNDS = "100,100,540,100,540,380,100,380"


@pytest.mark.parametrize("args, fragments", [
    (["estimate", "img.png", "--bounds", "1,2,3"], ["--bounds", "8 numbers", "'1,2,3'"]),
    (["estimate", "img.png", "--bounds", "1,2,3,4,5,6,7,x"], ["--bounds", "numbers"]),
    (["estimate", "img.png", "--bounds", BOUNDS, "--K", "500,500,320"], ["--K", "4 or 5 numbers"]),
    (["estimate", "img.png", "--bounds", BOUNDS, "--K", "-500,500,320,240"], ["--K", "focal lengths"]),
    (["estimate", "img.png", "--bounds", BOUNDS, "--board", "8x6"], ["--board", "COLSxROWSxSQUARE_M"]),
    (["estimate", "img.png", "--camera", "c.yml", "--K", "500,500,320,240"], ["--camera", "--K", "not both"]),
    (["estimate", "--cases", str(BUNDLED), "--camera", "c.yml", "--K", "500,500,320,240"], ["not both"]),
    (["estimate", "img.png", "--camera", "no/such/left.yml"], ["--camera: calibration file not found"]),
    (["estimate", "img.png", "--camera-name", "cam1"], ["--camera-name cam1", "no --camera"]),
    (["estimate", "--cases", "c.json", "--bounds", BOUNDS], ["--bounds goes with IMAGE"]),
    (["estimate", "img.png", "--bounds", BOUNDS], ["no camera", "--camera FILE", "--K FX,FY,CX,CY",
                                                   "graphpose calibrate"]),
    (["estimate", "--frobnicate"], ["unrecognized arguments: --frobnicate"]),
    (["estimate", "img.png", "--bounds", BOUNDS, "--overlay", "out.jpg"], ["--overlay", ".png"]),
    (["nonsense"], ["invalid choice"]),
    (["estimate", "img.png", "--cases", "c.json"], ["either IMAGE or --cases"]),
    (["estimate", "img.png", "--bounds", BOUNDS, "--guess", "g.json", "--no-guess"], ["contradict"]),
    (["estimate", "--cases", str(BUNDLED), "--guess", "g.json"], ["--guess goes with IMAGE"]),
    (["estimate", "--cases", str(BUNDLED), "--overlay", "many.png"], ["need a folder", "many.png"]),
    (["estimate", "--cases", str(BUNDLED), "--json", "no/such/folder/out.json"], ["--json", "does not exist"]),
    (["estimate", "--cases", "no/such/cases.json"], ["case file not found"]),
])
def test_usage_errors_in_process(args, fragments, capsys):
    # Argument errors never reach the pipeline, so the same main() runs in this process.
    assert main(args) == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and line.startswith("graphpose")
    for fragment in fragments:
        assert fragment in line, line


@pytest.mark.slow  # the command in many fresh processes
def test_malformed_values_as_a_user_sees_them():
    one_error_line(graphpose("estimate", "img.png", "--bounds", BOUNDS, "--board", "8by6"),
                   2, "graphpose estimate: error: argument --board", "'8by6'")
    one_error_line(graphpose("estimate", "img.png", "--bounds", "1,2,3,4"),
                   2, "graphpose estimate: error: argument --bounds", "8 numbers", "'1,2,3,4'")
    one_error_line(graphpose("estimate", "img.png", "--bounds", BOUNDS, "--K", "500,0,320,240"),
                   2, "graphpose estimate: error: argument --K", "focal lengths must be positive")


@pytest.mark.slow  # the command in several fresh processes
def test_missing_and_unreadable_image_and_guess(tmp_path):
    one_error_line(graphpose("estimate", tmp_path / "nope.png", "--bounds", BOUNDS, "--K", K_BUNDLED),
                   2, "not found", "nope.png")
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"this is not a png")
    one_error_line(graphpose("estimate", junk, "--bounds", BOUNDS, "--K", K_BUNDLED), 2, "cannot read", "junk.png")
    bad_guess = tmp_path / "guess.json"
    bad_guess.write_text("[[1, 0], [0, 1]]")
    one_error_line(graphpose("estimate", junk, "--bounds", BOUNDS, "--K", K_BUNDLED, "--guess", bad_guess),
                   2, "guess.json", "(4, 4)")


def test_a_folder_without_images_says_so(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("no image here")
    assert main(["estimate", str(tmp_path), "--bounds", BOUNDS, "--K", K_BUNDLED]) == 2
    line = capsys.readouterr().err.strip()
    assert line.startswith("graphpose estimate: error: no image files (.png") and str(tmp_path) in line, line


def test_readme_polygon_over_a_corner_of_the_board(capsys):
    # The README's example of a polygon that does not hold the board, as the user sees it.
    image = BUNDLED.parent / "synthetic_03.png"
    assert main(["estimate", str(image), "--bounds", "300,300,400,300,400,400,300,400", "--K", K_BUNDLED]) == 1
    line = capsys.readouterr().err.strip()
    # Nothing inside the bounds at the fast path's levels; a coarser level finds the board, and
    # the bounds, drawn over one of its corners, do not outline it.
    assert re.fullmatch(rf"graphpose estimate: error: {re.escape(str(image))}: the bounds do not outline the board found: "
                        r"their vertex 0 lies nearest the board's corner \d; give the board's outline clockwise "
                        r"from the corner nearest junction 0, its first edge along a row", line), line


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_no_board_found_exits_1(blank_png, tmp_path):
    out_json = tmp_path / "out.json"
    line = one_error_line(graphpose("estimate", blank_png, "--bounds", BOUNDS, "--K", K_BUNDLED, "--json", out_json,
                                    "--overlay", tmp_path / "o.png"), 1)
    assert "blank.png" in line
    (record,) = json.loads(out_json.read_text())
    assert record["message"] and not record["converged"] and record["T_WC"] is None
    # No pose, but a picture of what the search saw, and the error line says where it is.
    assert png_size(tmp_path / "o.png") == (640, 480) and f"its picture, with what was found: {tmp_path / 'o.png'}" in line
    assert record["message"] in line


def test_no_convergence_exits_1(bundled, tmp_path, monkeypatch, capsys):
    # Gauss-Newton capped at one iteration cannot converge: the estimate is unreliable and
    # must say so, with exit code 1, no report, a JSON record and the picture.
    import functools

    from graphpose import estimate as pipeline

    monkeypatch.setattr(pipeline, "gauss_newton", functools.partial(pipeline.gauss_newton, max_iterations=1))
    case = bundled.cases[0]
    bounds = ",".join(f"{u:g},{v:g}" for u, v in case.bounds.T)
    out_json = tmp_path / "out.json"
    code = main(["estimate", str(case.image), "--bounds", bounds, "--K", K_BUNDLED, "--json", str(out_json),
                 "--overlay", str(tmp_path / "o.png")])
    captured = capsys.readouterr()
    assert code == 1
    assert captured.out == ""  # an unreliable pose is not reported as a result
    (line,) = captured.err.strip().splitlines()
    assert line.startswith("graphpose estimate: error: ") and case.image.name in line
    assert "no reliable pose" in line and "iteration cap reached" in line
    (record,) = json.loads(out_json.read_text())
    assert record["message"] and "no reliable pose" in record["message"]
    assert not record["converged"] and record["iterations"] == 1
    assert png_size(tmp_path / "o.png") == (640, 480)  # the picture shows what went wrong


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_failed_overlay_write_is_that_images_error_and_the_batch_goes_on(bundled, tmp_path, capsys):
    doc = {"K": bundled.K.tolist(), "cases": [
        {"image": str(c.image), "bounds": c.bounds.tolist()} for c in bundled.cases[:2]]}
    cases_file = tmp_path / "cases.json"
    cases_file.write_text(json.dumps(doc))
    folder = tmp_path / "pictures"
    (folder / f"{bundled.cases[0].image.stem}.overlay.png").mkdir(parents=True)  # cannot be replaced
    out_json = tmp_path / "out.json"
    code = main(["estimate", "--cases", str(cases_file), "--json", str(out_json), "--overlay", str(folder), "-q"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "cannot write" in line and bundled.cases[0].image.stem in line
    first, second = json.loads(out_json.read_text())
    assert "cannot write" in first["message"] and first["T_WC"] is not None
    assert second["message"] is None and second["converged"]
    assert png_size(folder / f"{bundled.cases[1].image.stem}.overlay.png") == (640, 480)


def test_an_overlay_folder_that_cannot_be_made_is_an_input_error(bundled, tmp_path, capsys):
    case = bundled.cases[1]
    bounds = ",".join(f"{u:g},{v:g}" for u, v in case.bounds.T)
    (tmp_path / "taken").write_text("a file where the folder should go")
    out_json = tmp_path / "out.json"
    code = main(["estimate", str(case.image), "--bounds", bounds, "--K", K_BUNDLED, "--json", str(out_json),
                 "--overlay", f"{tmp_path / 'taken'}/", "-q"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "--overlay: cannot create folder" in line and "taken" in line
    (record,) = json.loads(out_json.read_text())
    assert "cannot create folder" in record["message"] and record["T_WC"] is not None


@pytest.mark.slow  # the command in a fresh process over a folder
def test_batch_goes_on_past_a_bad_image(bundled, blank_png, tmp_path):
    good = bundled.cases[2]
    doc = {"K": bundled.K.tolist(), "cases": [
        {"image": str(good.image), "bounds": good.bounds.tolist()},
        {"image": "missing.png", "bounds": good.bounds.tolist()},
        {"image": str(blank_png), "bounds": good.bounds.tolist()},
    ]}
    cases_file = tmp_path / "cases.json"
    cases_file.write_text(json.dumps(doc))
    result = graphpose("estimate", "--cases", cases_file, "--json", tmp_path / "out.json",
                       "--overlay", tmp_path / "pictures")
    assert result.returncode == 2  # the worst: a missing file is bad input
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 2 and "missing.png" in lines[0] and "blank.png" in lines[1]
    assert "3 images: 1 estimated, 2 failed" in result.stdout
    records = json.loads((tmp_path / "out.json").read_text())
    assert [r["message"] is None for r in records] == [True, False, False]
    assert records[0]["converged"] and "not found" in records[1]["message"]
    # The blank image has no pose but its picture (what the search saw); the missing one none.
    assert sorted(p.name for p in (tmp_path / "pictures").iterdir()) == ["blank.overlay.png",
                                                                        f"{good.image.stem}.overlay.png"]


# --- pieces, in process ----------------------------------------------------------------------


def test_no_arguments_means_estimate_on_the_bundled_example(monkeypatch):
    import graphpose.cli.estimate as estimate

    seen = []
    monkeypatch.setattr(estimate, "run", lambda args: seen.append(args) or 0)
    assert main([]) == 0
    (args,) = seen
    assert args.command == "estimate" and args.images == [] and args.cases is None
    assert estimate.DEFAULT_CASES == BUNDLED


def test_every_subcommand_follows_the_protocol():
    import importlib

    from graphpose.cli import SUBCOMMANDS, build_parser

    parser = build_parser()
    for name in SUBCOMMANDS:
        module = importlib.import_module(f"graphpose.cli.{name}")
        assert callable(module.add_parser) and callable(module.run)
        assert main([name, "--help"]) == 0
    assert parser.parse_args(["estimate"]).command == "estimate"


def test_help_names_the_defaults(capsys):
    assert main(["estimate", "--help"]) == 0
    text = capsys.readouterr().out
    assert "564.9,564.3,337.3,226.5" in text and "8x6x0.0635" in text and "project's" in text


def test_typed_values():
    np.testing.assert_array_equal(parse_bounds("1,2, 3,4,5,6,7,8"), [[1, 3, 5, 7], [2, 4, 6, 8]])
    np.testing.assert_array_equal(parse_bounds("-1.5,2,3,-4e1,5,6,7,8")[:, :2], [[-1.5, 3], [2, -40]])
    np.testing.assert_array_equal(parse_K("500,510,320,240"),
                                  [[500, 0, 320], [0, 510, 240], [0, 0, 1]])


def test_negative_lists_are_values_not_options(monkeypatch):
    import graphpose.cli.estimate as estimate

    seen = []
    monkeypatch.setattr(estimate, "run", lambda args: seen.append(args) or 0)
    assert main(["estimate", "a.png", "--bounds", "-3,-2.5,400,1,400,300,-1e1,300", "-q"]) == 0
    np.testing.assert_array_equal(seen[0].bounds, [[-3, 400, 400, -10], [-2.5, 1, 300, 300]])
    assert seen[0].quiet


def test_progress_bar_only_on_a_terminal():
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stream = Terminal()
    bar = Progress(4, stream, width=8)
    bar.show(2, "b.png")
    assert stream.getvalue() == "\r[####....] 2/4 b.png"
    bar.clear()
    assert stream.getvalue().endswith("\r" + " " * 20 + "\r")
    quiet = io.StringIO()
    Progress(4, quiet).show(1, "a.png")
    assert quiet.getvalue() == ""
    single = Terminal()
    Progress(1, single).show(0, "a.png")
    assert single.getvalue() == ""


@pytest.mark.parametrize("exception, code, message", [
    (KeyboardInterrupt, 130, "graphpose estimate: interrupted"),
    (BrokenPipeError, 1, ""),
])
def test_interrupt_and_closed_pipe(monkeypatch, capsys, exception, code, message):
    import graphpose.cli.estimate as estimate
    from graphpose import cli

    def run(args):
        raise exception

    redirected = []
    monkeypatch.setattr(estimate, "run", run)
    # Stand-ins for pointing stdout's descriptor at /dev/null, which would blind pytest's capture.
    monkeypatch.setattr(cli.sys, "stdout", SimpleNamespace(fileno=lambda: 101))
    monkeypatch.setattr(cli.os, "open", lambda path, flags: ("opened", path))
    monkeypatch.setattr(cli.os, "dup2", lambda fd, target: redirected.append((fd, target)))
    assert main(["estimate"]) == code
    assert capsys.readouterr().err.strip() == message
    assert redirected == ([(("opened", cli.os.devnull), 101)] if exception is BrokenPipeError else [])


def test_usage_errors_name_the_subcommand_as_typed(capsys):
    assert main(["render-sequence", "--frames", "x"]) == 2
    assert capsys.readouterr().err.startswith("graphpose render-sequence: error: argument --frames")


def test_a_case_file_without_cases_is_an_input_error(tmp_path, capsys):
    cases_file = tmp_path / "cases.json"
    cases_file.write_text(json.dumps({"K": np.eye(3).tolist(), "cases": []}))
    assert main(["estimate", "--cases", str(cases_file)]) == 2
    assert capsys.readouterr().err.strip() == f"graphpose estimate: error: case file {cases_file} has no cases"


def test_parse_K_takes_a_fifth_number_as_the_skew():
    np.testing.assert_array_equal(parse_K("500,510,320,240,1.5"), [[500, 1.5, 320], [0, 510, 240], [0, 0, 1]])
    with pytest.raises(argparse.ArgumentTypeError, match="4 or 5 numbers"):
        parse_K("500,510,320,240,1.5,2")


@pytest.mark.parametrize("text", ["0", "-1", "nan", "inf", "abc", ""])
def test_parse_positive_refuses(text):
    with pytest.raises(argparse.ArgumentTypeError, match="expected a positive number"):
        parse_positive(text)


def test_parse_positive_accepts():
    assert parse_positive("2.5") == 2.5 and parse_positive("1e-3") == 1e-3


# --- raw images with their camera, and no bounds ---------------------------------------------




@pytest.mark.slow  # the command in a fresh process on a raw image
def test_a_raw_image_with_its_calibration_file(tmp_path):
    # As docs/cli.md writes it, from the repository's root.
    image = os.path.relpath(opencv_file("left01.jpg"), REPO)  # ../shared/data/opencv_samples/left01.jpg
    camera = os.path.relpath(opencv_file("left.opencv.yml"), REPO)
    result = graphpose("estimate", image, "--camera", camera, "--board", "9x6x0.03",
                       "--json", tmp_path / "out.json", "--overlay", tmp_path / "left01.png", cwd=REPO)
    assert result.returncode == 0, result.stderr
    assert "(converged," in result.stdout and "over 54 junctions, 54 trusted" in result.stdout
    assert "agree" in result.stdout and "orientation" not in result.stdout
    (record,) = json.loads((tmp_path / "out.json").read_text())
    assert record["status"] == "ok" and record["orientation_ambiguous"] is False
    assert record["junction0_square"] == "dark"  # the colour rule's corner: no bounds
    assert record["reprojection_rms_px"] < 0.3  # 0.16 px; fitted as a pinhole the raw image gives 0.85
    assert png_size(tmp_path / "left01.png") == (640, 480)
    camera = read_camera(opencv_file("left.opencv.yml"))
    est = estimate_pose(read_image(opencv_file("left01.jpg")), camera, bounds=None, board=Board(9, 6, 0.03))
    dt, dr = pose_difference(est.T_WC, np.array(record["T_WC"]))
    assert dt < 1e-9 and dr < 1e-7


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_an_image_without_bounds_is_searched_whole_and_flagged_when_symmetric(tmp_path):
    real_file("target_01.png")
    result = graphpose("estimate", "../shared/data/rob501/target_01.png", "--K", K_BUNDLED, "--json",
                       tmp_path / "out.json", cwd=REPO)
    assert result.returncode == 0, result.stderr
    assert "(converged," in result.stdout and "over 48 junctions, 48 trusted" in result.stdout
    assert ("orientation     orientation ambiguous (half-turn symmetric board, no bounds): junction 0 is the "
            "corner nearest the image's upper left") in result.stdout
    (record,) = json.loads((tmp_path / "out.json").read_text())
    assert record["status"] == "ok" and record["orientation_ambiguous"] is True


def test_case_file_with_a_camera_file_or_object_and_no_bounds(tmp_path, capsys):
    camera = read_camera(opencv_file("right.opencv.xml"))
    write_camera(tmp_path / "right.json", camera)
    images = [str(opencv_file(name)) for name in ("right01.jpg", "right02.jpg")]
    common = {"grid": [9, 6], "square_m": 0.03, "cases": [{"image": image} for image in images]}
    records = []
    for entry in ("right.json", {"model": "radtan", "K": camera.K.tolist(), "distortion": camera.distortion.tolist(),
                                 "size": list(camera.size)}):
        path = tmp_path / "cases.json"
        path.write_text(json.dumps({"camera": entry, **common}))
        assert main(["estimate", "--cases", str(path), "--json", str(tmp_path / "out.json"), "-q"]) == 0
        records.append(json.loads((tmp_path / "out.json").read_text()))
    for a, b in zip(*records):
        assert a["status"] == b["status"] == "ok" and a["T_WC"] == b["T_WC"]
    # The command line's --K overrides the file's camera (and refuses --camera beside it):
    # without the lens model these raw images' junctions lie up to pixels off any planar
    # grid: a pose, where enough of them pass, fits several times worse, and where too few
    # pass the image is refused with the likely reason.
    assert main(["estimate", "--cases", str(path), "--K", "536.8,536.5,326.3,250.1", "--json", "-"]) == 1
    pinhole = json.loads(capsys.readouterr().out)
    for r, lens in zip(pinhole, records[0]):
        assert (r["status"] == "ok" and r["reprojection_rms_px"] > 3 * lens["reprojection_rms_px"]) or \
            (r["status"] == "failed" and "give the camera's calibration" in r["message"]), r
    assert {r["status"] for r in pinhole} == {"ok", "failed"}


def test_camera_name_chooses_the_camera_of_a_kalibr_camchain(tmp_path, capsys):
    # The chain holds the left camera as cam0 and the right one as cam1: a right image is
    # solved with cam1's lens only when --camera-name says so.
    chain, image = opencv_file("camchain.kalibr.yaml"), opencv_file("right01.jpg")
    board = Board(9, 6, 0.03)
    records = {}
    for name in (None, "cam0", "cam1"):
        args = ["estimate", str(image), "--camera", str(chain), "--board", "9x6x0.03", "--json", "-", "-q"]
        assert main(args + ([] if name is None else ["--camera-name", name])) == 0
        (records[name],) = json.loads(capsys.readouterr().out)
    assert records[None]["T_WC"] == records["cam0"]["T_WC"] != records["cam1"]["T_WC"]
    est = estimate_pose(read_image(image), read_camera(chain, name="cam1"), bounds=None, board=board)
    dt, dr = pose_difference(est.T_WC, np.array(records["cam1"]["T_WC"]))
    assert dt < 1e-9 and dr < 1e-7


@pytest.mark.parametrize("file, name, fragments", [
    ("camchain.kalibr.yaml", "cam2", ["--camera", "no camera 'cam2'", "it holds cam0, cam1"]),
    ("left.opencv.yml", "cam1", ["--camera", "holds one camera", "'cam1'"]),
    ("left.ros.yaml", "right", ["--camera", "asked for camera 'right'", "'left'"]),
])
def test_a_wrong_camera_name_is_one_clear_error_naming_what_the_file_holds(capsys, file, name, fragments):
    image = opencv_file("right01.jpg")
    assert main(["estimate", str(image), "--camera", str(opencv_file(file)), "--camera-name", name]) == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and line.startswith("graphpose estimate: error: ")
    for fragment in fragments:
        assert fragment in line, line


NAN_YML = ("%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
           "   data: [ 533.5, 0., .Nan, 0., 533.5, 235.2, 0., 0., 1. ]\n"
           "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
           "   data: [ -0.288, 0.097, 0.001, -0.0003, 0. ]\n")
MISSING_YML = ("%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
               "   data: [ 533.5, 0., 341.6, 0., 533.5, 235.2, 0., 0., 1. ]\n")
OMNI_YAML = ("cam0:\n  camera_model: omni\n  intrinsics: [0.8, 500, 500, 320, 240]\n  distortion_model: radtan\n"
             "  distortion_coeffs: [0, 0, 0, 0]\n  resolution: [640, 480]\n")


@pytest.mark.parametrize("name, text, fragments", [
    ("few.json", '{"model": "radtan", "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]], "distortion": [0.1, 0.01, 0]}',
     ["--camera", "few.json", "3 distortion coefficients"]),
    ("nan.yml", NAN_YML, ["--camera", "nan.yml", "NaN"]),
    ("missing.yml", MISSING_YML, ["--camera", "missing.yml", "distortion_coefficients"]),
    ("omni.yaml", OMNI_YAML, ["--camera", "omni", "not support"]),
    ("small.json", '{"model": "pinhole", "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]], "size": [800, 600]}',
     ["target_01.png is 640 x 480 pixels but the camera is calibrated for 800 x 600"]),
])
def test_bad_camera_files_are_one_clear_error(tmp_path, capsys, name, text, fragments):
    image = real_file("target_01.png")
    (tmp_path / name).write_text(text)
    assert main(["estimate", str(image), "--camera", str(tmp_path / name)]) == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and line.startswith("graphpose estimate: error: ")
    for fragment in fragments:
        assert fragment in line, line


# --- several images and folders --------------------------------------------------------------


def test_folders_and_images_in_name_order_into_one_json_list(bundled, tmp_path, capsys):
    folder = tmp_path / "shots"
    folder.mkdir()
    for name, case in zip(("c.png", "a.png", "b.png"), bundled.cases):
        os.symlink(case.image, folder / name)
    (folder / "notes.txt").write_text("not an image")
    single = tmp_path / "single.png"
    os.symlink(bundled.cases[3].image, single)
    out = tmp_path / "out.json"
    assert main(["estimate", str(folder), str(single), "--K", K_BUNDLED, "--json", str(out)]) == 0
    report = capsys.readouterr().out
    records = json.loads(out.read_text())
    assert [r["image"] for r in records] == [str(folder / n) for n in ("a.png", "b.png", "c.png")] + [str(single)]
    assert {r["status"] for r in records} == {"ok"} and "4 images: 4 estimated, 0 failed" in report
    # Paths as given: the symbolic links are not resolved, in the report either.
    assert f"{folder / 'a.png'}  (converged" in report
    truth = {str(folder / n): c.true_T_WC for n, c in zip(("c.png", "a.png", "b.png"), bundled.cases)}
    for r in records[:3]:
        assert pose_difference(np.array(r["T_WC"]), truth[r["image"]])[0] < 2e-3
    # Images given one by one keep the order given.
    assert main(["estimate", str(folder / "c.png"), str(folder / "a.png"), "--K", K_BUNDLED, "--json", "-"]) == 0
    assert [r["image"] for r in json.loads(capsys.readouterr().out)] == [str(folder / "c.png"), str(folder / "a.png")]


def test_opencv_samples_a_folder_of_left_images_and_right_images_as_paths(tmp_path, capsys):
    # The check on OpenCV's raw samples, two of each side (all 13 + 13 in the report).
    left = tmp_path / "left"
    left.mkdir()
    for name in ("left02.jpg", "left01.jpg"):
        os.symlink(opencv_file(name), left / name)
    assert main(["estimate", str(left), "--camera", str(opencv_file("left.opencv.yml")), "--board", "9x6x0.03",
                 "--json", "-"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert [Path(r["image"]).name for r in records] == ["left01.jpg", "left02.jpg"]
    assert all(r["status"] == "ok" and r["junctions_used"] == 54 for r in records)
    assert records[0]["camera"]["file"] == str(opencv_file("left.opencv.yml"))
    assert records[0]["board"] == {"cols": 9, "rows": 6, "square_m": 0.03}
    right = [str(opencv_file(n)) for n in ("right01.jpg", "right02.jpg")]
    assert main(["estimate", *right, "--camera", str(opencv_file("right.opencv.xml")), "--board", "9x6x0.03",
                 "--json", "-"]) == 0
    assert [r["status"] for r in json.loads(capsys.readouterr().out)] == ["ok", "ok"]
