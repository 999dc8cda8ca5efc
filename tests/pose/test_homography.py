import numpy as np
import pytest

from graphpose import DegenerateGeometryError, InputError
from graphpose.geometry import T_from_params, project, to_camera
from graphpose.pose.gauss_newton import gauss_newton
from graphpose.geometry import homography_dlt
from graphpose.pose.homography import on_target_plane, pose_from_homography
from tests.conftest import BOARD_WPTS as WPTS
from tests.conftest import PROJECT_K as K
from tests.helpers import random_pose


def test_exact_points_give_the_exact_pose():
    rng = np.random.default_rng(0)
    for _ in range(50):
        T = random_pose(rng=rng)
        np.testing.assert_allclose(pose_from_homography(project(K, T, WPTS), WPTS, K), T, atol=1e-8)


def test_homography_maps_source_to_destination():
    rng = np.random.default_rng(1)
    src = rng.uniform(-1, 1, (2, 10))
    H_true = np.array([[1.2, 0.1, 3.0], [-0.2, 0.9, -1.0], [1e-3, 2e-3, 1.0]])
    dst_h = H_true @ np.vstack([src, np.ones(10)])
    H = homography_dlt(src, dst_h[:2] / dst_h[2])
    np.testing.assert_allclose(H / H[2, 2], H_true, atol=1e-9)


def test_noisy_points_start_gauss_newton_at_the_same_minimum():
    rng = np.random.default_rng(2)
    for _ in range(20):
        T = random_pose(rng=rng)
        I = project(K, T, WPTS) + rng.normal(0, 0.5, (2, 48))
        T0 = pose_from_homography(I, WPTS, K)
        assert np.all(to_camera(T0, WPTS)[2] > 0)
        assert np.linalg.norm(T0[:3, 3] - T[:3, 3]) < 0.05
        from_lin = gauss_newton(I, WPTS, K, guess=T0)
        from_truth = gauss_newton(I, WPTS, K, guess=T)
        assert from_lin.converged and from_truth.converged
        # Both stop within rounding of the cost's minimum: far inside the 1e-6 m cross-check.
        np.testing.assert_allclose(from_lin.T_WC, from_truth.T_WC, atol=1e-7)


def test_four_points_are_enough():
    T = random_pose(rng=np.random.default_rng(3))
    W = WPTS[:, [0, 7, 40, 47]]
    np.testing.assert_allclose(pose_from_homography(project(K, T, W), W, K), T, atol=1e-8)


def test_result_is_a_rotation_with_board_in_front():
    T = pose_from_homography(project(K, T_from_params([0.2, 0.1, -0.9, 0.2, -0.1, 0.3]), WPTS)
                             + np.random.default_rng(4).normal(0, 2.0, (2, 48)),
                             WPTS, K)
    C = T[:3, :3]
    np.testing.assert_allclose(C.T @ C, np.eye(3), atol=1e-12)
    assert np.linalg.det(C) == pytest.approx(1.0)
    assert np.all(to_camera(T, WPTS)[2] > 0)


def test_collinear_points_are_refused():
    W = WPTS[:, :8]  # one row of the board
    I = project(K, T_from_params([0.2, 0.1, -0.9, 0.0, 0.0, 0.0]), W)
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        pose_from_homography(I, W, K)


def test_off_plane_points_are_refused():
    W = WPTS.copy()
    W[2, 5] = 0.01
    with pytest.raises(InputError, match="z = 0"):
        pose_from_homography(project(K, T_from_params([0.2, 0.1, -0.9, 0, 0, 0]), W), W, K)


def test_on_target_plane_tolerance_is_relative_to_the_extent():
    W = WPTS.copy()
    assert on_target_plane(W)
    W[2, 5] = 0.9e-6  # extent 0.4445 m < 1 m: the tolerance is 1e-6 m
    assert on_target_plane(W)
    W[2, 5] = -1.1e-6
    assert not on_target_plane(W)
    W[:2] *= 10  # extent 4.445 m: the tolerance is 4.445e-6 m
    assert on_target_plane(W)


@pytest.mark.parametrize(
    "K_, I_, W_, match",
    [
        (K, np.zeros((2, 3)), WPTS[:, :3], "at least 4"),
        (K, np.zeros((2, 48)), WPTS[:, :40], "same number"),
        (np.zeros((3, 3)), np.zeros((2, 48)), WPTS, "K"),
        (K, np.full((2, 48), np.nan), WPTS, "NaN"),
    ],
)
def test_bad_input_is_refused(K_, I_, W_, match):
    with pytest.raises(InputError, match=match):
        pose_from_homography(I_, W_, K_)


def test_the_compiled_split_is_the_svd_one():
    # The kernel's nearest rotation (the polar factor by Newton's iteration) and its back
    # substitution against NumPy's SVD and solve, on homographies far from a rigid one (the
    # columns of K^-1 H up to 30 % off orthonormal) and with a skewed K.
    from graphpose.pose._homography import homography_pose

    rng = np.random.default_rng(7)
    K_skew = K.copy()
    K_skew[0, 1] = 3.0
    for camera in (K, K_skew):
        for _ in range(40):
            T = random_pose(rng)
            H = camera @ np.column_stack([T[:3, :3].T[:, :2], -T[:3, :3].T @ T[:3, 3]])
            H = H @ (np.eye(3) + rng.uniform(-0.3, 0.3, (3, 3)) * [[1, 1, 0], [1, 1, 0], [0, 0, 0]])
            H *= rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 10.0)
            M = np.linalg.solve(camera, H)
            scale = 2.0 / (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1]))
            depth = M[2] @ np.vstack([WPTS[:2], np.ones(WPTS.shape[1])])
            if not (np.all(depth > 0) or np.all(depth < 0)):
                continue
            scale = -scale if np.all(depth < 0) else scale
            r1, r2, t = scale * M.T
            U, _, Vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
            R = U @ Vt
            out = np.empty((4, 4))
            assert homography_pose(camera, H, np.ascontiguousarray(WPTS[:2]), out)
            np.testing.assert_allclose(out[:3, :3], R.T, atol=1e-13)
            np.testing.assert_allclose(out[:3, 3], -R.T @ t, atol=1e-12)
            np.testing.assert_array_equal(out[3], [0, 0, 0, 1])


def test_points_on_both_sides_of_the_camera_are_refused(monkeypatch):
    from graphpose.pose import homography
    from graphpose.pose._homography import homography_pose

    # A homography that sends the board's plane through the camera: depths of both signs.
    H = K @ np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-5.0, 0.0, 1.0]])
    out = np.full((4, 4), 7.0)
    assert not homography_pose(K, H, np.ascontiguousarray(WPTS[:2]), out)
    assert np.all(out == 7.0)  # left as it was
    monkeypatch.setattr(homography, "homography_dlt", lambda src, dst: H)
    with pytest.raises(DegenerateGeometryError, match="in front"):
        pose_from_homography(project(K, random_pose(np.random.default_rng(1)), WPTS), WPTS, K)


def test_a_homography_with_parallel_plane_axes_is_refused_not_a_nan_pose(monkeypatch):
    from graphpose.pose import homography

    # The board's x and y axes imaged along one direction: r1 and r2 parallel, no rotation
    # near [r1 r2 r1 x r2] (its determinant is 0), so the polar factor is NaN.
    H = K @ np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    monkeypatch.setattr(homography, "homography_dlt", lambda src, dst: H)
    with pytest.raises(DegenerateGeometryError, match="no rotation"):
        pose_from_homography(project(K, random_pose(np.random.default_rng(1)), WPTS), WPTS, K)
