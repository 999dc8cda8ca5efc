"""``graphpose calibrate`` and the calibration's covariance in ``graphpose estimate --camera``.

Runs in process (``graphpose.cli.main``): a calibration of a few rendered views is the slow
part, so the runs are few and each checks several things.
"""

import json

import numpy as np
import pytest

from graphpose import Board, estimate_pose, read_camera, read_image
from graphpose.calibrate.params import camera_parameters, camera_with_parameters
from graphpose.cli import main
from graphpose.io.calibration import write_camera
from graphpose.synth import render
from tests.conftest import LENS_CAMERAS
from tests.pose.test_intrinsics import COV_K

BOARD = Board()
SIZE = (640, 480)


@pytest.fixture(scope="module")
def raw_view(tmp_path_factory):
    """One rendered raw image of the radtan camera, and its camera files with and without
    the covariance."""
    folder = tmp_path_factory.mktemp("raw-view")
    camera = LENS_CAMERAS["radtan"]
    rng = np.random.default_rng(21)
    scene = render.render(camera, render.random_pose(rng, camera, BOARD, SIZE), BOARD, SIZE, rng=rng)
    from graphpose.io.files import write_png

    write_png(folder / "view.png", scene.image)
    sized = camera_with_parameters(render_camera(camera), camera_parameters(camera), COV_K)
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
    est = estimate_pose(read_image(image, as_float=False), None, read_camera(raw_view / "with.json"), BOARD)
    np.testing.assert_allclose(record["sigma_xyz_m"], est.sigma_xyz_m, rtol=1e-9)
    np.testing.assert_allclose(record["sigma_rpy_deg"], np.degrees(est.sigma_rpy_rad), rtol=1e-9)
