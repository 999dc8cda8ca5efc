"""graphpose.camera_models.base: what every camera does (projection and its Jacobian, inverses
over whole images, calibration parameters and their Jacobian, the covariance, frozen values), the
pinhole camera, as_camera and check_image_size. (docs/cameras.md's examples run in
tests/test_docs.py, with every page's.)"""

import dataclasses

import numpy as np
import pytest

from graphpose import InputError
from graphpose.geometry import T_from_params, to_camera
from graphpose.geometry import project as pinhole_project
from graphpose.camera_models import (
    MODELS,
    UNPROJECT_TOL,
    FisheyeCamera,
    PinholeCamera,
    RadTanCamera,
    RationalCamera,
    as_camera,
    check_image_size,
    model_class,
)
from tests.camera_models.helpers import (
    CAMERAS,
    K,
    K_FISHEYE,
    K_SAMPLE,
    FISHEYE,
    RADTAN,
    RATIONAL,
    cameras,
    points_in_view,
    whole_image,
)
from tests.helpers import central_difference


# ---- projection, the pinhole ----------------------------------------------------------------


def test_pinhole_camera_is_the_seed_projection():
    K = [[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0.0, 0.0, 1.0]]
    T = T_from_params([0.1, 0.05, -1.0, 0.1, -0.2, 0.3])
    W = np.random.default_rng(4).uniform(-0.2, 0.2, (3, 50)) * [[1], [1], [0]]
    np.testing.assert_allclose(PinholeCamera(K).project(to_camera(T, W)),
                               pinhole_project(K, T, W), rtol=1e-13)


@pytest.mark.parametrize("camera", cameras(), ids=lambda c: f"{c.model}{c.distortion.size}")
def test_project_jacobian_matches_central_differences(camera):
    rng = np.random.default_rng(8)
    max_angle = np.radians(100 if camera.model == "fisheye" else 35)
    P = points_in_view(camera, 500, rng, max_angle)
    P[:, 0] = [0.0, 0.0, 1.3]  # on the axis
    uv, J = camera.project_jacobian(P)
    np.testing.assert_allclose(uv, camera.project(P), rtol=0, atol=1e-12)
    ref = central_difference(camera.project, P)
    scale = np.abs(ref).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(J / scale, ref / scale, rtol=0, atol=1e-7)


def test_gtsam_cal3_s2_is_the_pinhole():
    pytest.importorskip("gtsam")
    camera = cameras()[0]
    P = points_in_view(camera, 50, np.random.default_rng(11))
    cal = camera.gtsam_calibration()
    theirs = np.array([cal.uncalibrate(P[:2, j] / P[2, j]) for j in range(50)]).T
    np.testing.assert_allclose(theirs, camera.project(P), rtol=0, atol=1e-9)


# ---- inverses over whole images -------------------------------------------------------------


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("camera", cameras()[:4], ids=lambda c: f"{c.model}{c.distortion.size}")
def test_unproject_round_trip_over_whole_image(camera):
    uv = whole_image(camera, step=2.0)
    rays = camera.unproject(uv)
    assert not np.isnan(rays).any()
    np.testing.assert_allclose(np.linalg.norm(rays, axis=0), 1.0, atol=1e-14)
    # The stated accuracy: UNPROJECT_TOL normalised units, i.e. 1e-12 f pixels.
    assert np.abs(camera.project(rays) - uv).max() <= UNPROJECT_TOL * 2 * camera.fx
    # And back: rays through projected pixels are the same rays.
    np.testing.assert_allclose(camera.unproject(camera.project(rays)), rays, atol=1e-12)


@pytest.mark.parametrize("camera", cameras()[1:], ids=lambda c: f"{c.model}{c.distortion.size}")
def test_distort_and_undistort_are_inverse(camera):
    xy = np.random.default_rng(6).uniform(-0.5, 0.5, (2, 1000))
    np.testing.assert_allclose(camera.undistort(camera.distort(xy)), xy, atol=1e-11)
    uv = np.random.default_rng(7).uniform([0, 0], camera.size, (1000, 2)).T
    ideal = camera.undistort_pixels(uv)
    ok = ~np.isnan(ideal[0])
    assert ok.mean() > 0.5
    np.testing.assert_allclose(camera.distort_pixels(ideal[:, ok]), uv[:, ok], atol=1e-8)
    np.testing.assert_allclose(camera.pinhole().project(camera.unproject(uv[:, ok])),
                               ideal[:, ok], atol=1e-8)


# ---- calibration parameters -----------------------------------------------------------------


def points(camera, rng, n=40):
    """Camera-frame points in view: rays within 50 degrees (95 for the fisheye), 0.5-3 m."""
    limit = np.radians(95.0 if camera.model == "fisheye" else 50.0)
    theta = rng.uniform(0.0, limit, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    ray = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return ray * rng.uniform(0.5, 3.0, n)


def test_parameter_names_are_opencvs_order():
    assert MODELS["pinhole"].parameter_names == ("fx", "fy", "cx", "cy")
    assert MODELS["radtan"].parameter_names == ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
    assert MODELS["fisheye"].parameter_names == ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4")
    # An 8-coefficient RadTanCamera keeps k4..k6 fixed; model="rational" estimates them too.
    assert CAMERAS["rational"].parameter_names == MODELS["radtan"].parameter_names
    assert MODELS["rational"].parameter_names == MODELS["radtan"].parameter_names + ("k4", "k5", "k6")
    with pytest.raises(InputError, match="unknown camera model 'omni'.*pinhole, radtan, rational, fisheye"):
        model_class("omni")


@pytest.mark.parametrize("name", CAMERAS)
def test_parameters_match_their_names_and_round_trip(name):
    camera = CAMERAS[name]
    p = camera.parameters
    assert p.shape == (len(camera.parameter_names),) and p.dtype == float
    np.testing.assert_array_equal(p[:4], [camera.fx, camera.fy, camera.cx, camera.cy])
    p[0] = -1.0  # a new array each time: the camera stays as it was
    assert camera.parameters[0] == camera.fx
    p = camera.parameters
    again = camera.with_parameters(p)
    assert again == camera and type(again) is type(camera) and again.size == camera.size
    assert again.skew == camera.skew and again.covariance is None
    moved = camera.with_parameters(p * 1.01)
    np.testing.assert_allclose(moved.parameters, p * 1.01, rtol=1e-15)
    if name == "rational":  # k4..k6 are not parameters: kept
        np.testing.assert_array_equal(moved.coefficients[5:], camera.coefficients[5:])
    # The classmethod: this model's camera of the vector, the skew (not a parameter) given.
    made = type(camera).from_parameters(p, camera.size, skew=camera.skew)
    assert type(made) is type(camera) and made.size == camera.size
    np.testing.assert_array_equal(made.parameters, p)
    np.testing.assert_array_equal(made.K, camera.K)
    if name != "rational":  # an 8-coefficient RadTanCamera's k4..k6 come with rational=
        assert made == camera
    assert RadTanCamera.from_parameters(CAMERAS["rational"].parameters, (640, 480),
                                        rational=RATIONAL[5:]) == CAMERAS["rational"]


def parameter_central_difference(camera, P, h=1e-6):
    p = camera.parameters
    J = np.empty((P.shape[1], 2, p.size))
    for i in range(p.size):
        step = h * max(1.0, abs(p[i]))
        plus, minus = p.copy(), p.copy()
        plus[i] += step
        minus[i] -= step
        J[:, :, i] = ((camera.with_parameters(plus).project(P)
                       - camera.with_parameters(minus).project(P)) / (2 * step)).T
    return J


@pytest.mark.parametrize("name", CAMERAS)
def test_parameter_jacobian_matches_central_differences(name):
    camera = CAMERAS[name]
    P = points(camera, np.random.default_rng(5))
    J = camera.parameter_jacobian(P)
    assert J.shape == (P.shape[1], 2, len(camera.parameter_names))
    num = parameter_central_difference(camera, P)
    scale = np.max(np.abs(num), axis=(0, 1))  # per parameter
    np.testing.assert_allclose(J / scale, num / scale, rtol=0, atol=1e-7)


def test_parameter_jacobian_edges():
    # The pinhole's is the normalised point and the identity; the fisheye's forward axis has a
    # finite derivative (0 in the coefficients); points behind a radtan camera are NaN rows, as
    # project is NaN.
    J = PinholeCamera(K).parameter_jacobian([[0.1], [0.2], [1.0]])
    np.testing.assert_allclose(J[0], [[0.1, 0, 1, 0], [0, 0.2, 0, 1]])
    J = CAMERAS["fisheye"].parameter_jacobian([[0.0], [0.0], [2.0]])
    np.testing.assert_array_equal(J[0, :, 4:], 0.0)
    np.testing.assert_array_equal(J[0, :, 2:4], np.eye(2))
    J = CAMERAS["radtan5"].parameter_jacobian([[0.1, 0.1], [0.0, 0.0], [1.0, -1.0]])
    assert np.all(np.isfinite(J[0])) and np.all(np.isnan(J[1]))
    with pytest.raises(InputError, match=r"P_C must have shape \(3, N\)"):
        PinholeCamera(K).parameter_jacobian(np.zeros((2, 3)))


def spd(n, rng):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("name", CAMERAS)
def test_cameras_carry_a_read_only_covariance_outside_equality(name):
    camera = CAMERAS[name]
    n = len(camera.parameter_names)
    cov = spd(n, np.random.default_rng(n))
    with_cov = camera.with_parameters(camera.parameters, cov)
    np.testing.assert_array_equal(with_cov.covariance, cov)
    np.testing.assert_array_equal(type(camera).from_parameters(camera.parameters, covariance=cov,
                                                               skew=camera.skew).covariance, cov)
    with pytest.raises(ValueError):
        with_cov.covariance[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        with_cov.covariance = None
    # Equality is the projection's: a file format without a covariance reads back equal.
    assert with_cov == camera and hash(with_cov) == hash(camera)
    assert "covariance" not in repr(with_cov)


def test_covariance_checks():
    names = MODELS["radtan"].parameter_names
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


def test_from_parameters_refuses_bad_vectors():
    camera = CAMERAS["fisheye"]
    with pytest.raises(InputError, match="a fisheye camera has 8 parameters"):
        camera.with_parameters(np.ones(9))
    with pytest.raises(InputError, match="NaN"):
        camera.with_parameters([np.nan] * 8)
    with pytest.raises(InputError, match="focal lengths"):
        camera.with_parameters([-1.0, 1, 1, 1, 0, 0, 0, 0])
    with pytest.raises(InputError, match=r"a rational camera has 12 parameters \(fx, .*, k6\), got 9"):
        RationalCamera.from_parameters(CAMERAS["radtan5"].parameters)
    with pytest.raises(InputError, match="no skew"):
        RadTanCamera.from_parameters(CAMERAS["radtan5"].parameters, skew=0.5)


# ---- objects, coercion, checks --------------------------------------------------------------


def test_cameras_are_frozen_values():
    a = RadTanCamera(K_SAMPLE, RADTAN["4"], (640, 480))
    b = RadTanCamera(np.array(K_SAMPLE), np.r_[RADTAN["4"], 0.0], [640, 480])
    assert a == b and hash(a) == hash(b)  # k3 written as 0 is the same camera
    assert a != RadTanCamera(K_SAMPLE, RADTAN["4"])  # size unknown
    assert a != a.pinhole() and a.pinhole() == PinholeCamera(K_SAMPLE, (640, 480))
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.K = np.eye(3)
    with pytest.raises(ValueError):
        a.K[0, 0] = 1.0
    with pytest.raises(ValueError):
        a.distortion[0] = 1.0


def test_as_camera():
    camera = as_camera(K_SAMPLE)
    assert isinstance(camera, PinholeCamera) and camera.size is None
    np.testing.assert_array_equal(camera.K, K_SAMPLE)
    fisheye = FisheyeCamera(K_FISHEYE, FISHEYE)
    assert as_camera(fisheye) is fisheye
    with pytest.raises(InputError, match="focal lengths"):
        as_camera([[0.0, 0, 1], [0, 1, 1], [0, 0, 1]])


@pytest.mark.parametrize("make, message", [
    (lambda: RadTanCamera(K_SAMPLE, [0.1] * 6), r"6 distortion coefficients: 6 fits no model"),
    (lambda: RadTanCamera(K_SAMPLE, [0.1] * 14), r"14 coefficients are OpenCV's thin-prism"),
    (lambda: FisheyeCamera(K_SAMPLE, [0.1] * 5), r"FisheyeCamera got 5 .*RadTanCamera takes 5"),
    (lambda: RadTanCamera(K_SAMPLE, [0.1, np.nan, 0, 0]), "NaN"),
    (lambda: RadTanCamera(K_SAMPLE, np.zeros((2, 4))), "vector of coefficients"),
    (lambda: RadTanCamera([[500, 2, 320], [0, 500, 240], [0, 0, 1]], [0] * 4), "no skew"),
    (lambda: PinholeCamera([[500, 0, 320], [0, -500, 240], [0, 0, 1]]), "focal lengths"),
    (lambda: PinholeCamera([[500, 0, np.inf], [0, 500, 240], [0, 0, 1]]), "NaN or infinite"),
    (lambda: PinholeCamera(K_SAMPLE, (640, 0)), "size height"),
    (lambda: cameras()[0].project(np.zeros((2, 3))), r"P_C must have shape \(3, N\)"),
    (lambda: cameras()[0].unproject([[np.nan], [1.0]]), "uv contains NaN"),
])
def test_invalid_input_is_refused(make, message):
    with pytest.raises(InputError, match=message):
        make()


def test_check_image_size():
    camera = RadTanCamera(K_SAMPLE, RADTAN["4"], (640, 480))
    check_image_size(camera, (480, 640))
    check_image_size(camera, np.zeros((480, 640, 3)))
    check_image_size(K_SAMPLE, (1, 1))  # size unknown: anything goes
    with pytest.raises(InputError, match=r"left01.png is 800 x 600 pixels but the camera is "
                                         r"calibrated for 640 x 480"):
        check_image_size(camera, (600, 800), what="left01.png")
    with pytest.raises(InputError, match="height, width"):
        check_image_size(camera, (480,))
