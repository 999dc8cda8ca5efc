"""``graphpose calibrate`` and the calibration's covariance in ``graphpose estimate --camera``.

Runs in process (``graphpose.cli.main``): a calibration of a few rendered views is the slow
part, so the runs are few and each checks several things.
"""

import json

import numpy as np
import pytest

from graphpose import Board, estimate_pose, read_camera, read_image
from graphpose.cli import main
from graphpose.io.cameras import write_camera
from graphpose.synth import poses, render
from tests.conftest import LENS_CAMERAS
from tests.pose.test_covariance import COV_K

BOARD = Board()
SIZE = (640, 480)


@pytest.fixture(scope="module")
def raw_view(tmp_path_factory):
    """One rendered raw image of the radtan camera, and its camera files with and without
    the covariance."""
    folder = tmp_path_factory.mktemp("raw-view")
    camera = LENS_CAMERAS["radtan"]
    rng = np.random.default_rng(21)
    scene = render.render(camera, poses.random_pose(camera, BOARD, SIZE, rng=rng), BOARD, SIZE, rng=rng)
    from graphpose.io.files import write_png

    write_png(folder / "view.png", scene.image)
    sized = render_camera(camera).with_parameters(camera.parameters, COV_K)
    write_camera(folder / "with.json", sized)
    write_camera(folder / "without.json", render_camera(camera))
    return folder


def render_camera(camera):
    from dataclasses import replace

    return replace(camera, size=SIZE)


def test_estimate_reports_the_kind_of_its_sigmas(raw_view, capsys):
    image = raw_view / "view.png"
    out = {}
    for which in ("with", "without"):
        code = main(["estimate", str(image), "--camera", str(raw_view / f"{which}.json"),
                     "--json", str(raw_view / f"{which}.out.json")])
        assert code == 0
        out[which] = (capsys.readouterr().out, json.loads((raw_view / f"{which}.out.json").read_text())[0])
    text, record = out["with"]
    assert record["sigma_kind"] == "pixel noise and calibration"
    assert "1-sigma from    pixel noise and calibration; pixel noise alone:" in text
    plain_text, plain = out["without"]
    assert plain["sigma_kind"] == "pixel noise" and "1-sigma from" not in plain_text
    # The pixel noise's share is the plain estimate's sigma; the whole is larger.
    np.testing.assert_allclose(record["sigma_pixel_xyz_m"], plain["sigma_xyz_m"], rtol=1e-9)
    np.testing.assert_allclose(plain["sigma_pixel_xyz_m"], plain["sigma_xyz_m"], rtol=0)
    assert np.all(np.array(record["sigma_xyz_m"]) > np.array(plain["sigma_xyz_m"]))
    # And they are the library's figures.
    est = estimate_pose(read_image(image, as_float=False), read_camera(raw_view / "with.json"), bounds=None,
                        board=BOARD)
    np.testing.assert_allclose(record["sigma_xyz_m"], est.sigma_xyz_m, rtol=1e-9)
    np.testing.assert_allclose(record["sigma_rpy_deg"], np.degrees(est.sigma_rpy_rad), rtol=1e-9)


# ---- graphpose calibrate ---------------------------------------------------------------------
REPORT_KEYS = ["model", "K", "distortion", "size", "parameters", "covariance", "rms_px", "images"]
#: After them, where the board warp was estimated (calibrate's default warp="auto").
WARP_KEY = "board_warp"


def report_keys(report) -> bool:
    """The report's keys are REPORT_KEYS in order, then the board warp's where it was estimated."""
    keys = list(report)
    return keys in (REPORT_KEYS, REPORT_KEYS + [WARP_KEY])
IMAGE_KEYS = ["image", "status", "message", "rms_px", "T_WC", "outliers"]


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    """Six rendered raw views of the radtan calibration camera in a folder, and a blank image
    (no board) after them in name order; the set's truth."""
    from graphpose.io.files import write_png
    from graphpose.synth.calibration import calibration_set, radtan_camera

    folder = tmp_path_factory.mktemp("views")
    views = calibration_set(radtan_camera(), 6, rng=5)
    for k, image in enumerate(views.images):
        write_png(folder / f"view_{k:02d}.png", image)
    write_png(folder / "view_99_blank.png", np.full((480, 640), 128, np.uint8))
    return folder, views


@pytest.fixture(scope="module")
def calibrated_run(views, tmp_path_factory):
    """One whole run: camera file, report and picture; (exit code, stdout, stderr, folder)."""
    folder, _ = views
    out = tmp_path_factory.mktemp("out")
    import contextlib
    import io

    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(["calibrate", str(folder), "--board", "8x6x0.0635", "--model", "radtan",
                     "--out", str(out / "camera.json"), "--json", str(out / "report.json"),
                     "--plot", str(out / "calibration.png")])
    return code, stdout.getvalue(), stderr.getvalue(), out


@pytest.mark.slow  # a whole calibration through the CLI
def test_calibrate_writes_the_camera_the_report_and_the_picture(views, calibrated_run):
    from graphpose.camera_models import MODELS

    folder, truth_set = views
    code, stdout, stderr, out = calibrated_run
    assert code == 0, stderr
    report = json.loads((out / "report.json").read_text())
    assert report_keys(report)
    assert list(report["board_warp"]) == ["warp_m", "covariance_m2", "sag_mm", "sag_sigma_mm"]
    assert report["model"] == "radtan" and report["size"] == [640, 480]
    assert list(report["parameters"]) == list(MODELS["radtan"].parameter_names)
    images = report["images"]
    assert [list(i) for i in images] == [IMAGE_KEYS] * 7
    assert [i["image"] for i in images] == [str(folder / f"view_{k:02d}.png") for k in range(6)] + [
        str(folder / "view_99_blank.png")]
    assert [i["status"] for i in images] == ["used"] * 6 + ["no board"]
    blank = images[-1]
    assert blank["T_WC"] is None and blank["rms_px"] is None and blank["message"]
    # The poses are the views' (the camera in the board's frame), to a few mm.
    for record, rendering in zip(images, truth_set.renderings):
        assert np.allclose(np.array(record["T_WC"])[:3, 3], rendering.T_WC[:3, 3], atol=3e-3)
        assert 0.0 < record["rms_px"] < 0.05
    # Every junction of the six views is in view: rms_px over all is the RMS of the images'.
    per_image = np.array([i["rms_px"] for i in images[:6]])
    assert report["rms_px"] == pytest.approx(np.sqrt(np.mean(per_image ** 2)), rel=1e-9)
    # The camera file: the report's camera with its covariance, within 3 sigma of the truth.
    camera = read_camera(out / "camera.json")
    np.testing.assert_array_equal(camera.K, report["K"])
    np.testing.assert_array_equal(camera.distortion, report["distortion"])
    np.testing.assert_array_equal(camera.covariance, report["covariance"])
    z = (camera.parameters - truth_set.camera.parameters) / np.sqrt(np.diag(camera.covariance))
    assert np.all(np.abs(z) < 3.0), z
    assert (out / "calibration.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The summary names the images, the figures and the file.
    assert "radtan camera, 640 x 480 pixels, from 7 images: 6 used, 0 rejected, 1 without a board" in stdout
    assert "px RMS over 288 junctions" in stdout and f"{out / 'camera.json'} (json, with the covariance)" in stdout
    assert "view_99_blank.png" in stdout and "no board" in stdout
    assert stderr == ""  # no progress bar off a terminal, no note


@pytest.mark.slow  # 3.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_calibrated_camera_file_carries_into_estimate(views, calibrated_run, capsys):
    folder, _ = views
    out = calibrated_run[3]
    assert main(["estimate", str(folder / "view_00.png"), "--camera", str(out / "camera.json"),
                 "--board", "8x6x0.0635", "--json", str(out / "pose.json")]) == 0
    record = json.loads((out / "pose.json").read_text())[0]
    assert record["sigma_kind"] == "pixel noise and calibration"
    assert np.all(np.array(record["sigma_xyz_m"]) > np.array(record["sigma_pixel_xyz_m"]))
    assert "pixel noise alone" in capsys.readouterr().out


@pytest.fixture()
def one_calibration(views, monkeypatch):
    """graphpose.calibrate replaced by the first call's answer, for the runs that test what is
    written around it."""
    import graphpose.calibrate as package

    folder, truth_set = views
    cached = {}
    real = package.calibrate

    def calibrate(files, model, *, board, **kwargs):
        key = (tuple(map(str, files)), model)
        if key not in cached:
            cached[key] = real(files, model, board=board, **kwargs)
        else:
            kwargs["progress"]("solve", 1, 1)
        return cached[key]

    monkeypatch.setattr(package, "calibrate", calibrate)
    return folder


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("fmt", ["opencv", "ros"])
def test_other_formats_and_the_note_that_they_drop_the_covariance(one_calibration, tmp_path, capsys, fmt):
    folder = one_calibration
    files = [str(folder / f"view_{k:02d}.png") for k in range(4)]
    assert main(["calibrate", *files, "--board", "8x6x0.0635", "--out", str(tmp_path / "cam.yaml"),
                 "--format", fmt, "-q"]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.strip() == (f"graphpose calibrate: note: the {fmt} format has no place for the intrinsics' "
                                    f"covariance: it is not in the file (the json format keeps it, and 'graphpose "
                                    f"estimate --camera' then reports sigmas that include it)")
    camera = read_camera(tmp_path / "cam.yaml")
    assert camera.model == "radtan" and camera.covariance is None and camera.size == (640, 480)


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_kalibr_takes_the_fisheye_and_pinhole_models(one_calibration, tmp_path, capsys):
    folder = one_calibration
    files = [str(folder / f"view_{k:02d}.png") for k in range(6)]
    assert main(["calibrate", *files, "--board", "8x6x0.0635", "--model", "pinhole",
                 "--out", str(tmp_path / "chain.yaml"), "--format", "kalibr", "-q"]) == 0
    camera = read_camera(tmp_path / "chain.yaml")
    assert camera.model == "pinhole" and camera.size == (640, 480)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_json_report_on_stdout_and_a_progress_bar_on_a_terminal(one_calibration, tmp_path, capsys, monkeypatch):
    import io

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    folder = one_calibration
    files = [str(folder / f"view_{k:02d}.png") for k in range(4)]
    terminal = Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    assert main(["calibrate", *files, "--board", "8x6x0.0635", "--out", str(tmp_path / "c.json"), "--json", "-"]) == 0
    report = json.loads(capsys.readouterr().out)  # the report alone
    assert report_keys(report) and len(report["images"]) == 4
    assert "first pass" in terminal.getvalue() and "] 4/4 " in terminal.getvalue()
    assert terminal.getvalue().endswith("\r")  # cleared at the end


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_failed_calibration_exits_1_and_writes_the_report_only(views, tmp_path, capsys, monkeypatch):
    from graphpose.calibrate import run as calibrate_run

    folder, _ = views
    monkeypatch.setattr(calibrate_run, "CROSS_CHECK_TOL", 0.0)  # the two solvers never agree
    files = [str(folder / f"view_{k:02d}.png") for k in range(4)]
    code = main(["calibrate", *files, "--board", "8x6x0.0635", "--out", str(tmp_path / "c.json"),
                 "--json", str(tmp_path / "r.json")])
    assert code == 1
    line = capsys.readouterr().err.strip()
    assert line.startswith("graphpose calibrate: error: calibration failed:") and "disagree" in line
    assert line.endswith("(no camera file written)")
    assert not (tmp_path / "c.json").exists()
    assert report_keys(json.loads((tmp_path / "r.json").read_text()))


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_usage_and_input_errors_exit_2_with_one_line(views, tmp_path, capsys, monkeypatch):
    folder, _ = views
    board = ["--board", "8x6x0.0635"]
    out = ["--out", str(tmp_path / "c.json")]
    view = str(folder / "view_00.png")
    cases = [
        (["calibrate", view, *out], "the following arguments are required: --board"),
        (["calibrate", view, *board], "the following arguments are required: --out"),
        (["calibrate", view, *board, *out, "--model", "omni"], "argument --model: invalid choice: 'omni'"),
        (["calibrate", view, *board, *out, "--format", "matlab"], "argument --format: invalid choice: 'matlab'"),
        (["calibrate", str(tmp_path / "none.png"), *board, *out], f"image file not found: {tmp_path / 'none.png'}"),
        (["calibrate", view, *board, "--out", str(tmp_path / "no" / "c.json")], "--out: folder"),
        (["calibrate", view, *board, *out, "--json", str(tmp_path / "no" / "r.json")], "--report: folder"),
        (["calibrate", view, *board, *out, "--plot", str(tmp_path / "p.jpg")], "the name must end in .png"),
        (["calibrate", view, *board, *out, "--format", "kalibr"],
         "--format kalibr cannot hold --model radtan: Kalibr's radtan keeps four coefficients"),
        (["calibrate", view, str(folder / "view_99_blank.png"), str(folder / "view_01.png"), *board, *out],
         "fewer than 3 images show the board (2 of 3)"),
    ]
    for args, fragment in cases:
        assert main(args) == 2, args
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and fragment in lines[0], (args, lines)
    assert not (tmp_path / "c.json").exists()
    monkeypatch.setitem(__import__("sys").modules, "matplotlib", None)  # the plot extra not installed
    assert main(["calibrate", view, *board, *out, "--plot", str(tmp_path / "p.png")]) == 2
    assert "graphpose calibrate --plot needs matplotlib (the plot extra): pip install" in capsys.readouterr().err
