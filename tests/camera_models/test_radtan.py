"""graphpose.camera_models.radtan: the radial-tangential and rational cameras against OpenCV's
definitions and GTSAM's Cal3DS2, their inverse on the unfolded branch only, OpenCV's five
parameters, the rational model's twelve and their Jacobian."""

import numpy as np
import pytest

from graphpose import InputError
from graphpose.camera_models import MODELS, PinholeCamera, RadTanCamera, RationalCamera
from tests.camera_models.helpers import CAMERAS, K_SAMPLE, RADTAN, normalised, points_in_view, whole_image

# The rational model's camera (model="rational", mrcal's OPENCV8).
K = [[530.0, 0.0, 322.0], [0.0, 528.0, 241.0], [0.0, 0.0, 1.0]]
D = [-0.25, 0.08, 0.001, -0.0005, 0.01, 0.05, -0.02, 0.01]


@pytest.mark.parametrize("count", list(RADTAN))
def test_radtan_projects_as_opencv(count):
    cv2 = pytest.importorskip("cv2")
    camera = RadTanCamera(K_SAMPLE, RADTAN[count])
    P = points_in_view(camera, 2000, np.random.default_rng(1), np.radians(40))
    ref, _ = cv2.projectPoints(P.T.copy(), np.zeros(3), np.zeros(3),
                               np.array(K_SAMPLE), np.array(RADTAN[count]))
    np.testing.assert_allclose(camera.project(P), ref[:, 0, :].T, rtol=0, atol=1e-8)


def test_zero_distortion_is_the_pinhole():
    P = points_in_view(None, 300, np.random.default_rng(5))
    pinhole = PinholeCamera(K_SAMPLE)
    np.testing.assert_allclose(RadTanCamera(K_SAMPLE, np.zeros(8)).project(P),
                               pinhole.project(P), rtol=1e-14)


def test_unproject_is_nan_past_a_radial_fold():
    # k1 = -0.5: r (1 - 0.5 r^2) peaks at r = 0.816, r_d = 0.544 and falls to 0 at r = 1.41;
    # past the peak no ray reaches, though flipped rays (through r > 1.41, g < 0) solve
    # distort(x) = x_d there: those are not the pixel's ray.
    camera = RadTanCamera(K_SAMPLE, (-0.5, 0.0, 0.0, 0.0))
    r_fold = np.sqrt(1 / 1.5)
    r_d = r_fold * (1 - 0.5 * r_fold ** 2)
    radius = np.r_[np.linspace(0.05, 0.99, 20), np.linspace(1.01, 4.0, 60)] * r_d
    angle = np.linspace(0, 2 * np.pi, radius.size)
    xy = camera.undistort(radius * np.stack([np.cos(angle), np.sin(angle)]))
    inside = radius < r_d
    assert np.isfinite(xy[:, inside]).all() and np.isnan(xy[:, ~inside]).all()
    assert np.hypot(*xy[:, inside]).max() < r_fold
    np.testing.assert_allclose(camera.distort(xy[:, inside]),
                               radius[inside] * np.stack([np.cos(angle), np.sin(angle)])[:, inside],
                               atol=1e-12)


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_unproject_answers_only_on_the_unfolded_branch():
    # Pincushion then a fold (k2 < 0) with strong tangential terms: where Newton ends on
    # the folded-back branch (the lens map turns the image over there) the answer is NaN.
    camera = RadTanCamera(K_SAMPLE, (0.3, -0.5, 0.1, 0.1))
    xy = camera.undistort(np.random.default_rng(12).uniform(-2, 2, (2, 5000)))
    xy = xy[:, ~np.isnan(xy[0])]
    h = 1e-7
    dx = (camera.distort(xy + [[h], [0]]) - camera.distort(xy - [[h], [0]])) / (2 * h)
    dy = (camera.distort(xy + [[0], [h]]) - camera.distort(xy - [[0], [h]])) / (2 * h)
    assert xy.shape[1] > 500 and np.all(dx[0] * dy[1] - dx[1] * dy[0] > 0)


def test_opencv_undistort_agrees():
    cv2 = pytest.importorskip("cv2")
    camera = RadTanCamera(K_SAMPLE, RADTAN["5"], (640, 480))
    uv = whole_image(camera, step=40.0)
    ref = cv2.undistortPoints(uv.T[:, None, :].copy(), np.array(K_SAMPLE),
                              np.array(RADTAN["5"]), criteria=(
                                  cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15))
    np.testing.assert_allclose(camera.undistort(normalised(camera, uv)), ref[:, 0, :].T,
                               atol=1e-7)


def test_gtsam_cal3ds2_is_opencv_radtan_without_k3():
    gtsam = pytest.importorskip("gtsam")
    camera = RadTanCamera(K_SAMPLE, RADTAN["4"])
    cal = camera.gtsam_calibration()
    assert isinstance(cal, gtsam.Cal3DS2)
    P = points_in_view(camera, 200, np.random.default_rng(9), np.radians(35))
    xy = P[:2] / P[2]
    ours = camera.project(P)
    theirs = np.array([cal.uncalibrate(xy[:, j]) for j in range(xy.shape[1])]).T
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-9)
    # The same through a GTSAM camera at the identity pose: Pose3's camera frame is ours.
    gcam = gtsam.PinholeCameraCal3DS2(gtsam.Pose3(), cal)
    theirs = np.array([gcam.project(P[:, j]) for j in range(P.shape[1])]).T
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-9)
    # calibrate() inverts to GTSAM's own tolerance (1e-5, the default it builds with).
    back = np.array([cal.calibrate(ours[:, j]) for j in range(P.shape[1])]).T
    np.testing.assert_allclose(back, camera.undistort(normalised(camera, ours)), atol=1e-4)


def test_gtsam_has_no_calibration_for_k3_or_the_rational_model():
    gtsam = pytest.importorskip("gtsam")
    for count in ("5", "8"):
        camera = RadTanCamera(K_SAMPLE, RADTAN[count])
        assert camera.gtsam_calibration() is None
        # What Cal3DS2 would make of the first four alone is another projection.
        cal = gtsam.Cal3DS2(camera.fx, camera.fy, 0.0, camera.cx, camera.cy, *RADTAN[count][:4])
        x = np.array([0.4, 0.3])
        assert np.abs(cal.uncalibrate(x) - camera.project(np.r_[x, 1.0][:, None])[:, 0]).max() > 0.1
    # A radial-tangential camera whose k3..k6 are written but zero is a Cal3DS2.
    assert isinstance(RadTanCamera(K_SAMPLE, np.r_[RADTAN["4"], np.zeros(4)]).gtsam_calibration(),
                      gtsam.Cal3DS2)


def test_radtan_parameters_are_opencvs_five():
    camera = CAMERAS["radtan4"]
    p = camera.parameters
    np.testing.assert_array_equal(p[4:], [-0.288, 0.097, 0.001, -0.0003, 0.0])
    p[8] = 0.02
    assert camera.with_parameters(p).distortion.tolist() == [-0.288, 0.097, 0.001, -0.0003, 0.02]


def test_twelve_parameters_and_their_jacobian():
    camera = RationalCamera(K, D, (640, 480))
    assert camera.model == "rational" and MODELS["rational"].parameter_names == camera.parameter_names
    assert len(camera.parameter_names) == 12
    p = camera.parameters
    np.testing.assert_array_equal(p[4:], D)
    P = np.array([[0.1, -0.3, 0.4], [0.05, 0.2, -0.1], [1.0, 1.2, 0.9]])
    J = camera.parameter_jacobian(P)
    for k in range(12):
        dp = np.zeros(12)
        dp[k] = 1e-6 * max(1.0, abs(p[k]))
        numeric = (camera.with_parameters(p + dp).project(P)
                   - camera.with_parameters(p - dp).project(P)) / (2 * dp[k])
        np.testing.assert_allclose(J[:, :, k], numeric.T, rtol=1e-5, atol=1e-6)
    # Projects as the 8-coefficient radial-tangential camera, and equals it.
    assert camera == RadTanCamera(K, D, (640, 480))
    with pytest.raises(InputError, match="8 coefficients"):
        RationalCamera(K, D[:5])
