"""Camera models: OpenCV's definitions (against OpenCV itself), inverses over whole images,
analytic Jacobians against central differences, GTSAM's calibrations against ours, checks.
(docs/cameras.md's examples run in tests/test_docs.py, with every page's.)"""

import dataclasses

import numpy as np
import pytest

from graphpose import InputError
from graphpose.geometry import T_from_params, to_camera
from graphpose.geometry import project as pinhole_project
from graphpose.camera_models import (
    UNPROJECT_TOL,
    FisheyeCamera,
    PinholeCamera,
    RadTanCamera,
    as_camera,
    check_image_size,
)
from tests.helpers import central_difference

# The left camera of OpenCV's stereo samples (its README), and stronger lenses.
K_SAMPLE = [[533.5, 0.0, 341.6], [0.0, 533.5, 235.2], [0.0, 0.0, 1.0]]
RADTAN = {
    "4": (-0.288, 0.097, 0.001, -0.0003),
    "5": (-0.35, 0.15, 0.001, -0.0003, -0.03),
    "8": (2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3),  # OpenCV's rational model
}
# A fisheye of about 220 degrees: 190 degrees fit the 1280 x 1024 image vertically, the
# model folds back at about 112 degrees off the axis, inside the image's corners.
K_FISHEYE = [[300.0, 0.9, 640.0], [0.0, 310.0, 512.0], [0.0, 0.0, 1.0]]
FISHEYE = (-0.013, -0.004, 0.0035, -0.001)


def cameras():
    """One camera of each model and coefficient count."""
    out = [PinholeCamera([[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0, 0, 1]], (640, 480))]
    out += [RadTanCamera(K_SAMPLE, d, (640, 480)) for d in RADTAN.values()]
    out.append(FisheyeCamera(K_FISHEYE, FISHEYE, (1280, 1024)))
    return out


def normalised(camera, uv):
    """``K^-1 [u, v, 1]``, the first two rows."""
    return np.linalg.solve(camera.K, np.vstack([uv, np.ones(uv.shape[1])]))[:2]


def to_pixels(camera, xy):
    """``K [x, y, 1]``, the first two rows."""
    return (camera.K @ np.vstack([xy, np.ones(xy.shape[1])]))[:2]


def whole_image(camera, step=4.0):
    """Pixels on a grid over the whole image, its border rows and columns included."""
    width, height = camera.size
    us = np.unique(np.r_[np.arange(0.0, width, step), width - 1.0])
    vs = np.unique(np.r_[np.arange(0.0, height, step), height - 1.0])
    u, v = np.meshgrid(us, vs)
    return np.stack([u.ravel(), v.ravel()])


def points_in_view(camera, n, rng, max_angle=None):
    """Camera-frame points on rays up to ``max_angle`` (60 degrees) off the axis, 0.3 to 3 m
    away."""
    max_angle = np.radians(60) if max_angle is None else max_angle
    theta = np.arccos(rng.uniform(np.cos(max_angle), 1.0, n))
    phi = rng.uniform(-np.pi, np.pi, n)
    rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return rays * rng.uniform(0.3, 3.0, n)


# ---- OpenCV's definitions ---------------------------------------------------------------
@pytest.mark.parametrize("count", list(RADTAN))
def test_radtan_projects_as_opencv(count):
    cv2 = pytest.importorskip("cv2")
    camera = RadTanCamera(K_SAMPLE, RADTAN[count])
    P = points_in_view(camera, 2000, np.random.default_rng(1), np.radians(40))
    ref, _ = cv2.projectPoints(P.T.copy(), np.zeros(3), np.zeros(3),
                               np.array(K_SAMPLE), np.array(RADTAN[count]))
    np.testing.assert_allclose(camera.project(P), ref[:, 0, :].T, rtol=0, atol=1e-8)


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


def test_pinhole_camera_is_the_seed_projection():
    K = [[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0.0, 0.0, 1.0]]
    T = T_from_params([0.1, 0.05, -1.0, 0.1, -0.2, 0.3])
    W = np.random.default_rng(4).uniform(-0.2, 0.2, (3, 50)) * [[1], [1], [0]]
    np.testing.assert_allclose(PinholeCamera(K).project(to_camera(T, W)),
                               pinhole_project(K, T, W), rtol=1e-13)


def test_zero_distortion_is_the_pinhole():
    P = points_in_view(None, 300, np.random.default_rng(5))
    pinhole = PinholeCamera(K_SAMPLE)
    np.testing.assert_allclose(RadTanCamera(K_SAMPLE, np.zeros(8)).project(P),
                               pinhole.project(P), rtol=1e-14)


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


# ---- inverses over whole images ---------------------------------------------------------
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


# ---- Jacobians --------------------------------------------------------------------------

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


# ---- GTSAM's calibrations ----------------------------------------------------------------
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


def test_gtsam_cal3_s2_is_the_pinhole():
    pytest.importorskip("gtsam")
    camera = cameras()[0]
    P = points_in_view(camera, 50, np.random.default_rng(11))
    cal = camera.gtsam_calibration()
    theirs = np.array([cal.uncalibrate(P[:2, j] / P[2, j]) for j in range(50)]).T
    np.testing.assert_allclose(theirs, camera.project(P), rtol=0, atol=1e-9)


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
