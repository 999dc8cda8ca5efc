"""graphpose.calibrate.zhang: the closed-form start of a calibration. Zhang's intrinsics from
exact homographies are the camera's K; boards all parallel are refused; the starting cameras and
poses of each model; the fisheye start's focal length of an equidistant lens."""

import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, InputError, K_from_params, PinholeCamera
from graphpose.calibrate.zhang import fisheye_start, start, zhang_intrinsics
from graphpose.camera_models import RadTanCamera, RationalCamera
from graphpose.geometry import T_from_params, pose_difference, to_camera
from graphpose.synth.poses import random_pose

BOARD = Board()
W = BOARD.world_points()
SIZE = (640, 480)
K = K_from_params(530.0, 526.0, 322.5, 241.0)


def views(camera, n, seed):
    rng = np.random.default_rng(seed)
    poses = [random_pose(camera, BOARD, rng=rng, distance=(0.4, 0.8), max_tilt_deg=50) for _ in range(n)]
    return poses, [(camera.project(to_camera(T, W)), W) for T in poses]


@pytest.fixture(scope="module")
def pinhole_views():
    """Five tilted views of the board through the pinhole K (drawn once: drawing is the slow part)."""
    return views(PinholeCamera(K, SIZE), 5, 1)


def homography(T):
    """The board plane (x, y, 1) to pixels of the pinhole K at pose T_WC: K [r1 r2 t] of T_CW."""
    T_CW = np.linalg.inv(T)
    return K @ np.column_stack([T_CW[:3, 0], T_CW[:3, 1], T_CW[:3, 3]])


def test_exact_homographies_give_the_cameras_K(pinhole_views):
    poses = pinhole_views[0][:4]
    Hs = [homography(T) * s for T, s in zip(poses, (1.0, -2.0, 0.3, 7.0))]  # any scale, any sign
    np.testing.assert_allclose(zhang_intrinsics(Hs, SIZE), K, rtol=1e-9, atol=1e-9)
    # Three views are the fewest that fix the five unknowns.
    np.testing.assert_allclose(zhang_intrinsics(Hs[:3], SIZE), K, rtol=1e-8, atol=1e-8)


def test_boards_all_parallel_do_not_fix_the_focal_length():
    # The board at one tilt, moved about in its own plane and along the axis: each homography
    # adds no new constraint on the focal length.
    base = T_from_params([0.1, 0.05, -0.6, 0.3, -0.2, 0.1])
    poses = [base @ T_from_params([dx, dy, 0.0, 0.0, 0.0, 0.0]) for dx, dy in ((0, 0), (0.05, 0), (0, 0.04), (-0.03, 0.02))]
    with pytest.raises(InputError, match="the views do not constrain the focal length"):
        zhang_intrinsics([homography(T) for T in poses], SIZE)
    with pytest.raises(InputError, match="the views do not constrain the focal length"):
        zhang_intrinsics([homography(T) for T in poses[:2]], SIZE)  # two views: four equations


@pytest.mark.parametrize("model, cls, n_coefficients", [
    ("pinhole", PinholeCamera, 0), ("radtan", RadTanCamera, 5), ("rational", RationalCamera, 8)])
def test_start_gives_each_model_zero_distortion_and_the_poses(pinhole_views, model, cls, n_coefficients):
    poses, observations = pinhole_views
    begin, starts = start(model, SIZE, observations)
    assert type(begin) is cls and begin.size == SIZE
    np.testing.assert_array_equal(begin.distortion, np.zeros(n_coefficients))
    np.testing.assert_allclose(begin.K, K, rtol=1e-8, atol=1e-8)
    for T, T_true in zip(starts, poses):
        dt, dr = pose_difference(T, T_true)
        assert dt < 1e-8 and dr < 1e-6


def test_fisheye_start_finds_an_equidistant_lens_s_focal_length():
    # An equidistant lens (k = 0) centred in the image: the start is that camera, to the
    # golden-section search's tolerance.
    f = 210.0
    lens = FisheyeCamera(K_from_params(f, f, 319.5, 239.5), np.zeros(4), SIZE)
    _, observations = views(lens, 3, 3)
    found = fisheye_start(SIZE, observations)
    assert type(found) is FisheyeCamera and found.size == SIZE
    assert (found.cx, found.cy) == (319.5, 239.5)
    np.testing.assert_array_equal(found.distortion, np.zeros(4))
    assert found.fx == found.fy and found.fx == pytest.approx(f, rel=1e-3)
