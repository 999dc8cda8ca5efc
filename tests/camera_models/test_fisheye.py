"""graphpose.camera_models.fisheye: the fisheye camera against OpenCV's definitions (skew
included) and GTSAM's Cal3Fisheye, rays past 90 degrees, its inverse to the image's edge."""

import numpy as np
import pytest

from graphpose.camera_models import UNPROJECT_TOL, FisheyeCamera
from tests.camera_models.helpers import (
    FISHEYE,
    K_FISHEYE,
    cameras,
    normalised,
    points_in_view,
    to_pixels,
    whole_image,
)


def test_fisheye_projects_as_opencv_with_skew():
    cv2 = pytest.importorskip("cv2")
    camera = FisheyeCamera(K_FISHEYE, FISHEYE)
    P = points_in_view(camera, 2000, np.random.default_rng(2), np.radians(85))
    ref, _ = cv2.fisheye.projectPoints(P.T[:, None, :].copy(), np.zeros(3), np.zeros(3),
                                       np.array(K_FISHEYE), np.array(FISHEYE),
                                       alpha=camera.skew / camera.fx)
    np.testing.assert_allclose(camera.project(P), ref[:, 0, :].T, rtol=0, atol=1e-8)


def test_fisheye_distort_matches_opencv_distortPoints():
    cv2 = pytest.importorskip("cv2")
    camera = FisheyeCamera(K_FISHEYE, FISHEYE)
    xy = np.random.default_rng(3).uniform(-3, 3, (2, 500))
    ref = cv2.fisheye.distortPoints(xy.T[:, None, :].copy(), np.array(K_FISHEYE),
                                    np.array(FISHEYE), alpha=camera.skew / camera.fx)
    np.testing.assert_allclose(to_pixels(camera, camera.distort(xy)), ref[:, 0, :].T, atol=1e-8)


def test_points_behind_are_nan_and_fisheye_sees_past_90_degrees():
    P = np.array([[0.1, 0.1, 1.0, 0.0, 0.0], [0.0, 0.2, 0.0, 0.0, 0.0],
                  [1.0, -1.0, -0.2, 0.0, -1.0]])
    for camera in cameras()[:2]:
        uv = camera.project(P)
        assert np.all(np.isfinite(uv[:, 0])) and np.all(np.isnan(uv[:, 1:]))
    uv, J = FisheyeCamera(K_FISHEYE, FISHEYE).project_jacobian(P)
    # (1, 0, -0.2) is 101 degrees off the axis; the origin and the backward axis have no pixel.
    assert np.all(np.isfinite(uv[:, :3])) and np.all(np.isnan(uv[:, 3:]))
    assert np.all(np.isfinite(J[:3])) and np.all(np.isnan(J[3:]))


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_fisheye_unproject_over_whole_image_to_its_edge():
    camera = FisheyeCamera(K_FISHEYE, FISHEYE, (1280, 1024))
    uv = whole_image(camera, step=2.0)
    rays = camera.unproject(uv)
    found = ~np.isnan(rays[0])
    angle = np.degrees(np.arccos(np.clip(rays[2, found], -1, 1)))
    # The image reaches 95 degrees off the axis (a 190 degree field of view) and beyond.
    assert angle.max() > 95.0
    assert np.degrees(camera.theta_max) == pytest.approx(angle.max(), abs=0.5)
    np.testing.assert_allclose(camera.project(rays[:, found]), uv[:, found], rtol=0,
                               atol=UNPROJECT_TOL * 2 * camera.fx * np.pi)
    # A pixel is NaN only beyond the radius where the model folds back, never a wrong ray.
    radius = np.hypot(*normalised(camera, uv))
    t = camera.theta_max
    edge = t * (1 + np.polyval(np.r_[camera.distortion[::-1], 0.0], t * t))
    assert np.all(radius[~found] > edge * (1 - 1e-12)) and np.all(radius[found] <= edge * (1 + 1e-12))


def test_fisheye_rays_to_190_degrees_round_trip():
    camera = FisheyeCamera(K_FISHEYE, FISHEYE)
    theta = np.radians(np.linspace(0.0, 95.0, 400))
    phi = np.linspace(-np.pi, np.pi, 400)
    rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    back = camera.unproject(camera.project(rays))
    assert np.linalg.norm(back - rays, axis=0).max() < 1e-10  # radians, nearly


def test_gtsam_cal3fisheye_is_opencv_fisheye_in_front():
    gtsam = pytest.importorskip("gtsam")
    camera = FisheyeCamera(K_FISHEYE, FISHEYE)
    cal = camera.gtsam_calibration()
    assert isinstance(cal, gtsam.Cal3Fisheye)
    P = points_in_view(camera, 200, np.random.default_rng(10), np.radians(85))
    xy = P[:2] / P[2]
    ours = camera.project(P)
    theirs = np.array([cal.uncalibrate(xy[:, j]) for j in range(xy.shape[1])]).T
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-9)
    gcam = gtsam.PinholeCameraCal3Fisheye(gtsam.Pose3(), cal)
    theirs = np.array([gcam.project(P[:, j]) for j in range(P.shape[1])]).T
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-9)
    near = ours[:, np.arctan(np.hypot(*xy)) < np.radians(60)]
    back = np.array([cal.calibrate(near[:, j]) for j in range(near.shape[1])]).T
    np.testing.assert_allclose(back, camera.undistort(normalised(camera, near)), atol=1e-4)
