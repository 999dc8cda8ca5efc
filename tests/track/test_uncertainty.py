"""graphpose.track.uncertainty: a tracked frame's covariance with the calibration's."""

import numpy as np
from scipy.optimize import least_squares

from graphpose import Board
from graphpose.camera_models import RadTanCamera
from graphpose.geometry import T_from_params, params_from_T, to_camera
from graphpose.pose.covariance import SIGMA_CALIBRATION, SIGMA_PIXEL
from graphpose.track.uncertainty import frame_covariance
from tests.conftest import PROJECT_K as K

W = Board().world_points()
T = T_from_params([0.2, 0.15, -0.9, 0.1, -0.08, 0.05])
CAMERA = RadTanCamera(K, [-0.28, 0.09, 0.001, -0.0005], size=(640, 480))
COV_PIXEL = np.diag([1e-6, 2e-6, 4e-6, 1e-5, 2e-5, 3e-6])


def _resection(camera, uv):
    """The pose parameters that best reproject W onto uv through camera (scipy's solver)."""
    residual = lambda p: (camera.project(to_camera(T_from_params(p), W)) - uv).ravel()  # noqa: E731
    return least_squares(residual, params_from_T(T), xtol=1e-15, ftol=1e-15, gtol=1e-15).x


def test_a_camera_without_covariance_gives_the_pixel_covariance():
    cov, kind = frame_covariance(CAMERA, T, W, COV_PIXEL)
    assert kind == SIGMA_PIXEL
    assert cov is COV_PIXEL


def test_the_calibration_term_is_the_resections_sensitivity_to_the_intrinsics():
    # D = d(pose)/d(intrinsics) by central differences: the junctions seen through the true
    # camera, re-solved through a camera with one parameter moved either way.
    k = CAMERA.parameters
    uv = CAMERA.project(to_camera(T, W))
    D = np.zeros((6, k.size))
    for i in range(k.size):
        h = 1e-4 * max(abs(k[i]), 1e-2)
        plus, minus = k.copy(), k.copy()
        plus[i] += h
        minus[i] -= h
        D[:, i] = (_resection(CAMERA.with_parameters(plus), uv) - _resection(CAMERA.with_parameters(minus), uv)) / (2 * h)
    A = np.random.default_rng(1).normal(size=(k.size, k.size))
    cov_k = A @ A.T * 1e-4 * np.outer(np.maximum(np.abs(k), 1e-2), np.maximum(np.abs(k), 1e-2))
    cov, kind = frame_covariance(CAMERA.with_parameters(k, cov_k), T, W, COV_PIXEL)
    assert kind == SIGMA_CALIBRATION
    expected = COV_PIXEL + D @ cov_k @ D.T
    np.testing.assert_allclose(cov, expected, rtol=1e-4, atol=1e-12)
    np.testing.assert_allclose(cov, cov.T, atol=0)
    assert np.all(np.linalg.eigvalsh(cov - COV_PIXEL) > -1e-15)  # the calibration only adds


def test_a_frame_that_cannot_be_propagated_gives_nan_of_the_calibration_kind():
    camera = CAMERA.with_parameters(CAMERA.parameters, np.eye(CAMERA.parameters.size) * 1e-6)
    behind = W + [[0.0], [0.0], [-5.0]]  # the points behind the camera: no projection to differentiate
    cov, kind = frame_covariance(camera, T, behind, COV_PIXEL)
    assert kind == SIGMA_CALIBRATION
    assert cov.shape == (6, 6) and np.isnan(cov).all()
