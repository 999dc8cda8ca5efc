"""graphpose.synth.calibration: the two ready cameras and calibration sets with exact truth."""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.camera_models import PinholeCamera
from graphpose.geometry import to_camera
from graphpose.synth.calibration import CalibrationSet, calibration_set, fisheye_camera, radtan_camera

BOARD = Board(5, 4, 0.05)  # a small board: a quick render


def _angles(camera, uv):
    """Angle of each pixel's ray off the optical axis, degrees."""
    xyz = camera.unproject(uv)
    return np.degrees(np.arctan2(np.hypot(xyz[0], xyz[1]), xyz[2]))


def test_the_ready_cameras():
    rt, fe = radtan_camera(), fisheye_camera()
    assert (rt.model, rt.size, fe.model, fe.size) == ("radtan", (640, 480), "fisheye", (1280, 960))
    assert rt.distortion[0] == -0.3  # strong barrel distortion: the image's corners pulled in
    corner = np.array([[0.0], [0.0]])
    assert np.hypot(*(rt.undistort_pixels(corner) - [[rt.cx], [rt.cy]])) > np.hypot(rt.cx, rt.cy)
    # About 185 degrees across: the rays of the image's left and right edges on its middle row.
    edges = np.array([[0.0, 1279.0], [fe.cy, fe.cy]])
    assert _angles(fe, edges).sum() == pytest.approx(185.0, abs=10.0)


def test_a_set_is_its_views_truth():
    camera = radtan_camera()
    views = calibration_set(camera, 3, rng=1, board=BOARD, noise_sigma=0.0)
    assert isinstance(views, CalibrationSet) and views.camera is camera and views.board == BOARD
    assert len(views.images) == len(views.poses) == 3
    W = BOARD.world_points()
    width, height = camera.size
    for r, image, T in zip(views.renderings, views.images, views.poses):
        assert image.shape == (height, width) and image.dtype == np.uint8
        np.testing.assert_allclose(r.junctions, camera.project(to_camera(T, W)), atol=1e-9)
        assert np.all((r.junctions >= 0) & (r.junctions <= np.array([[width - 1], [height - 1]])))
        # Tilted between 15 and 50 degrees: the board's normal against its centre's ray.
        centre = to_camera(T, W.mean(axis=1, keepdims=True))[:, 0]
        normal = np.linalg.inv(T)[:3, :3] @ [0.0, 0.0, 1.0]
        tilt = np.degrees(np.arccos(abs(normal @ centre) / np.linalg.norm(centre)))
        assert 15.0 - 1e-6 <= tilt <= 50.0 + 1e-6
    # The views are apart: the boards' centres land in different places.
    centres = [r.junctions.mean(axis=1) for r in views.renderings]
    assert min(np.hypot(*(a - b)) for i, a in enumerate(centres) for b in centres[i + 1:]) > 40.0


def test_a_fisheye_set_keeps_every_junction_within_the_angle():
    camera = fisheye_camera()
    views = calibration_set(camera, 2, rng=1, board=BOARD, max_angle_deg=60.0)
    for r in views.renderings:
        P_C = to_camera(r.T_WC, BOARD.world_points())
        assert np.degrees(np.arctan2(np.hypot(P_C[0], P_C[1]), P_C[2])).max() < 60.0


def test_a_seed_repeats_the_set():
    a = calibration_set(radtan_camera(), 2, rng=7, board=BOARD)
    b = calibration_set(radtan_camera(), 2, rng=np.random.default_rng(7), board=BOARD)
    for x, y in zip(a.images, b.images):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("call, match", [
    (lambda: calibration_set(PinholeCamera(np.diag([500.0, 500.0, 1.0])), 2), "image size"),
    (lambda: calibration_set(radtan_camera(), 0), "n_views"),
    (lambda: calibration_set(radtan_camera(), 2, min_tilt_deg=40.0, max_tilt_deg=20.0), "max_tilt_deg"),
    (lambda: calibration_set(radtan_camera(), 2, max_angle_deg=0.0), "max_angle_deg"),
])
def test_input_errors(call, match):
    with pytest.raises(InputError, match=match):
        call()
