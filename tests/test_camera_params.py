"""The calibration's parameter vectors: names in OpenCV's order, round trips through cameras,
the analytic intrinsic Jacobian against central differences, and the cameras' covariance."""

import dataclasses

import numpy as np
import pytest

import graphpose
from graphpose import FisheyeCamera, InputError, PinholeCamera, RadTanCamera
from graphpose.calibrate import (
    camera_parameters,
    camera_with_parameters,
    parameter_names,
    projection_jacobian_intrinsics,
)
from tests.helpers import central_difference

K = [[533.5, 0.0, 341.6], [0.0, 531.0, 235.2], [0.0, 0.0, 1.0]]
K_SKEW = [[300.0, 0.9, 640.0], [0.0, 310.0, 512.0], [0.0, 0.0, 1.0]]
CAMERAS = {
    "pinhole": PinholeCamera([[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0, 0, 1]], (640, 480)),
    "radtan4": RadTanCamera(K, (-0.288, 0.097, 0.001, -0.0003), (640, 480)),
    "radtan5": RadTanCamera(K, (-0.35, 0.15, 0.001, -0.0003, -0.03), (640, 480)),
    "rational": RadTanCamera(K, (2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3), (640, 480)),
    "fisheye": FisheyeCamera(K_SKEW, (-0.013, -0.004, 0.0035, -0.001), (1280, 1024)),
}


def points(camera, rng, n=40):
    """Camera-frame points in view: rays within 50 degrees (95 for the fisheye), 0.5-3 m."""
    limit = np.radians(95.0 if camera.model == "fisheye" else 50.0)
    theta = rng.uniform(0.0, limit, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    ray = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return ray * rng.uniform(0.5, 3.0, n)


def test_parameter_names_are_opencvs_order():
    assert parameter_names("pinhole") == ("fx", "fy", "cx", "cy")
    assert parameter_names("radtan") == ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
    assert parameter_names("fisheye") == ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4")
    # An 8-coefficient RadTanCamera keeps k4..k6 fixed; model="rational" estimates them too.
    assert parameter_names(CAMERAS["rational"]) == parameter_names("radtan")
    assert parameter_names("rational") == parameter_names("radtan") + ("k4", "k5", "k6")
    assert graphpose.calibrate.parameter_names is parameter_names
    with pytest.raises(InputError, match="unknown camera model 'omni'.*pinhole, radtan, rational, fisheye"):
        parameter_names("omni")


@pytest.mark.parametrize("name", CAMERAS)
def test_parameters_round_trip(name):
    camera = CAMERAS[name]
    p = camera_parameters(camera)
    assert p.shape == (len(parameter_names(camera)),)
    np.testing.assert_array_equal(p[:4], [camera.fx, camera.fy, camera.cx, camera.cy])
    again = camera_with_parameters(camera, p)
    assert again == camera and type(again) is type(camera) and again.size == camera.size
    assert again.skew == camera.skew and again.covariance is None
    moved = camera_with_parameters(camera, p * 1.01)
    np.testing.assert_allclose(camera_parameters(moved), p * 1.01, rtol=1e-15)
    if name == "rational":  # k4..k6 are not parameters: kept
        np.testing.assert_array_equal(moved.coefficients[5:], camera.coefficients[5:])


def test_radtan_parameters_are_opencvs_five():
    camera = CAMERAS["radtan4"]
    p = camera_parameters(camera)
    np.testing.assert_array_equal(p[4:], [-0.288, 0.097, 0.001, -0.0003, 0.0])
    p[8] = 0.02
    assert camera_with_parameters(camera, p).distortion.tolist() == [-0.288, 0.097, 0.001, -0.0003, 0.02]


@pytest.mark.parametrize("name", CAMERAS)
def test_intrinsic_jacobian_matches_central_differences(name):
    camera = CAMERAS[name]
    P = points(camera, np.random.default_rng(5))
    J = projection_jacobian_intrinsics(camera, P)
    assert J.shape == (P.shape[1], 2, len(parameter_names(camera)))
    num = central_difference(lambda p: camera_with_parameters(camera, p).project(P), camera_parameters(camera),
                             relative=True)
    scale = np.max(np.abs(num), axis=(0, 1))  # per parameter
    np.testing.assert_allclose(J / scale, num / scale, rtol=0, atol=1e-7)


def test_intrinsic_jacobian_edges():
    # A pinhole K is a PinholeCamera; the fisheye's forward axis has a finite derivative (0 in
    # the coefficients); points behind a radtan camera are NaN rows, as project is NaN.
    J = projection_jacobian_intrinsics(K, [[0.1], [0.2], [1.0]])
    np.testing.assert_allclose(J[0], [[0.1, 0, 1, 0], [0, 0.2, 0, 1]])
    J = projection_jacobian_intrinsics(CAMERAS["fisheye"], [[0.0], [0.0], [2.0]])
    np.testing.assert_array_equal(J[0, :, 4:], 0.0)
    np.testing.assert_array_equal(J[0, :, 2:4], np.eye(2))
    J = projection_jacobian_intrinsics(CAMERAS["radtan5"], [[0.1, 0.1], [0.0, 0.0], [1.0, -1.0]])
    assert np.all(np.isfinite(J[0])) and np.all(np.isnan(J[1]))
    with pytest.raises(InputError, match=r"P_C must have shape \(3, N\)"):
        projection_jacobian_intrinsics(K, np.zeros((2, 3)))


def spd(n, rng):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("name", CAMERAS)
def test_cameras_carry_a_read_only_covariance_outside_equality(name):
    camera = CAMERAS[name]
    n = len(parameter_names(camera))
    cov = spd(n, np.random.default_rng(n))
    with_cov = camera_with_parameters(camera, camera_parameters(camera), cov)
    np.testing.assert_array_equal(with_cov.covariance, cov)
    with pytest.raises(ValueError):
        with_cov.covariance[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        with_cov.covariance = None
    # Equality is the projection's: a file format without a covariance reads back equal.
    assert with_cov == camera and hash(with_cov) == hash(camera)
    assert "covariance" not in repr(with_cov)


def test_covariance_checks():
    names = parameter_names("radtan")
    good = np.diag([0.25, 0.25, 0.5, 0.5, 1e-6, 1e-5, 1e-8, 1e-8, 1e-4])
    RadTanCamera(K, [0, 0, 0, 0, 0], covariance=good)
    RadTanCamera(K, [0, 0, 0, 0, 0], covariance=np.zeros((9, 9)))  # a fixed parameter: 0 variance
    bad = [
        (np.eye(4), r"shape \(9, 9\)"),
        (np.full((9, 9), np.nan), "NaN"),
        (good - 2 * np.diag(np.diag(good)), "negative variances"),
        (good + np.triu(np.full((9, 9), 1e-6), 1), "not symmetric"),
        (good + 0.9 * np.sqrt(np.outer(np.diag(good), np.diag(good))) * (1 - np.eye(9)) * -1,
         "not positive semi-definite"),
        ([["a"] * 9] * 9, "real numbers"),
    ]
    for cov, message in bad:
        with pytest.raises(InputError, match=message):
            RadTanCamera(K, [0, 0, 0, 0, 0], covariance=cov)
    with pytest.raises(InputError, match=r"FisheyeCamera covariance \(of fx, fy, cx, cy, k1, k2, k3, k4\)"):
        FisheyeCamera(K, [0, 0, 0, 0], covariance=np.eye(9))
    with pytest.raises(InputError, match="PinholeCamera covariance"):
        PinholeCamera(K, covariance=np.eye(len(names)))


def test_camera_with_parameters_refuses_bad_vectors():
    camera = CAMERAS["fisheye"]
    with pytest.raises(InputError, match="a fisheye camera has 8 parameters"):
        camera_with_parameters(camera, np.ones(9))
    with pytest.raises(InputError, match="NaN"):
        camera_with_parameters(camera, [np.nan] * 8)
    with pytest.raises(InputError, match="focal lengths"):
        camera_with_parameters(camera, [-1.0, 1, 1, 1, 0, 0, 0, 0])
    with pytest.raises(InputError, match="must be a graphpose camera"):
        camera_parameters(np.eye(3))
