"""``graphpose calibrate``'s issue-30 options: --corners-out, --corners (with --image-size),
--cross-validate, and the projection uncertainty and outliers in the report."""

import json

import numpy as np
import pytest

from graphpose.cli import main
from graphpose.io.files import write_png
from graphpose.synth.calibration import calibration_set, radtan_camera


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shots")
    views = calibration_set(radtan_camera(), 8, rng=3)
    for k, image in enumerate(views.images):
        write_png(folder / f"v{k}.png", np.repeat(image[:, :, None], 3, axis=2))
    return folder


@pytest.mark.slow  # whole calibrations through the CLI, twice, and a cross-validation
def test_corners_out_in_and_cross_validation(shots, capsys, tmp_path):
    vnl, cv = tmp_path / "corners.vnl", tmp_path / "cv.png"
    code = main(["calibrate", str(shots), "--board", "8x6x0.0635", "--out", str(tmp_path / "cam.json"),
                 "--corners-out", str(vnl), "--cross-validate", str(cv), "--json", str(tmp_path / "r.json")])
    out = capsys.readouterr().out
    assert code == 0
    assert "uncertainty" in out and "px at the centre" in out
    assert "cross-validate  odd and even views (4 + 4): projection difference" in out
    assert cv.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    lines = vnl.read_text().splitlines()
    assert lines[0] == "# filename x y level" and len(lines) == 1 + 8 * 48
    report = json.loads((tmp_path / "r.json").read_text())
    assert all(image["outliers"] == [] for image in report["images"])
    # From the written corners, no images: the same camera.
    code = main(["calibrate", "--corners", str(vnl), "--image-size", "640x480", "--board", "8x6x0.0635",
                 "--out", str(tmp_path / "again.json")])
    assert code == 0
    a = json.loads((tmp_path / "cam.json").read_text())
    b = json.loads((tmp_path / "again.json").read_text())
    sd = np.sqrt(np.diag(np.array(a["covariance"])))
    assert np.all(np.abs(np.array(list(a["parameters"].values())) - np.array(list(b["parameters"].values()))) < 0.01 * sd)
    capsys.readouterr()
    # Without --image-size the first image the vnl names is read for its size.
    assert main(["calibrate", "--corners", str(vnl), "--board", "8x6x0.0635", "--out", str(tmp_path / "3.json"), "-q"]) == 0
    # --warp on: the board warp's line and its report; --warp off: a flat board, no such key.
    for warp, shown in (("on", True), ("off", False)):
        capsys.readouterr()
        assert main(["calibrate", "--corners", str(vnl), "--image-size", "640x480", "--board", "8x6x0.0635",
                     "--out", str(tmp_path / f"w{warp}.json"), "--warp", warp,
                     "--report", str(tmp_path / f"r{warp}.json")]) == 0
        assert ("board warp      sag" in capsys.readouterr().out) is shown
        report = json.loads((tmp_path / f"r{warp}.json").read_text())
        assert ("board_warp" in report) is shown
        if shown:
            assert abs(report["board_warp"]["sag_mm"]) < 4 * report["board_warp"]["sag_sigma_mm"] + 0.05


@pytest.mark.slow  # 1.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_usage_errors(shots, capsys, tmp_path):
    for argv, message in (
            ([str(shots), "--corners", "x.vnl"], "either IMAGES or --corners"),
            ([], "give the IMAGES"),
            ([str(shots), "--image-size", "640x480"], "--image-size goes with --corners"),
            ([str(shots), "--corners-out", str(tmp_path / "c.txt")], ".vnl"),
            ([str(shots), "--cross-validate", str(tmp_path / "c.jpg")], ".png"),
            ([str(shots), "--warp", "maybe"], "--warp")):
        code = main(["calibrate", *argv, "--board", "8x6x0.0635", "--out", str(tmp_path / "c.json")])
        assert code == 2, argv
        assert message in capsys.readouterr().err, argv
    assert main(["calibrate", "--corners", str(tmp_path / "none.vnl"), "--image-size", "64x48", "--board",
                 "8x6x0.0635", "--out", str(tmp_path / "c.json")]) == 2
    assert "not found" in capsys.readouterr().err


def test_a_board_taken_as_flat_by_warp_auto_says_why():
    from types import SimpleNamespace

    from graphpose.cli.calibrate_extras import after

    note = "the views disagree on its bending: each view's own warp against the others' gives chi-square 153 for 24 dof"
    calibration = SimpleNamespace(warp_m=None, warp_note=note, joint_cov=None)
    args = SimpleNamespace(corners_out=None, cross_validate=None)
    assert after(args, calibration) == [f"  board warp      flat (warp auto): {note}"]
    assert after(args, SimpleNamespace(warp_m=None, warp_note=None, joint_cov=None)) == []
