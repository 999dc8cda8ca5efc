import numpy as np
import pytest

from graphpose._checks import check_K
from graphpose.geometry import (
    C_from_rpy,
    T_from_params,
    params_from_T,
    project,
    rpy_from_C,
    to_camera,
)


def test_euler_round_trip_random():
    rng = np.random.default_rng(0)
    for _ in range(500):
        rpy = rng.uniform([-np.pi, -np.pi / 2, -np.pi], [np.pi, np.pi / 2, np.pi])
        C = C_from_rpy(*rpy)
        np.testing.assert_allclose(C.T @ C, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(rpy_from_C(C), rpy, atol=1e-9)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
def test_euler_gimbal_lock_reproduces_rotation(pitch):
    C = C_from_rpy(0.3, pitch, -1.1)
    rpy = rpy_from_C(C)
    assert rpy[0] == 0.0
    np.testing.assert_allclose(C_from_rpy(*rpy), C, atol=1e-9)


def test_euler_order_is_zyx():
    # A pure yaw turns x into y; roll then pitch then yaw are applied in that order.
    np.testing.assert_allclose(C_from_rpy(0, 0, np.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    C = C_from_rpy(0.1, 0.2, 0.3)
    Cx = C_from_rpy(0.1, 0, 0)
    Cy = C_from_rpy(0, 0.2, 0)
    Cz = C_from_rpy(0, 0, 0.3)
    np.testing.assert_allclose(C, Cz @ Cy @ Cx, atol=1e-12)


def test_params_round_trip():
    p = np.array([0.2, -0.1, -1.2, 3.0, 0.4, -2.0])
    np.testing.assert_allclose(params_from_T(T_from_params(p)), p, atol=1e-12)


def test_project_centre_of_fronto_parallel_camera():
    K = check_K([[500, 0, 320], [0, 500, 240], [0, 0, 1]])
    T = T_from_params([0.1, 0.2, -1.0, 0, 0, 0])
    uv = project(K, T, [[0.1, 0.2], [0.2, 0.2], [0.0, 0.0]])
    np.testing.assert_allclose(uv, [[320, 370], [240, 240]])
    assert to_camera(T, [[0.1], [0.2], [0.0]])[2, 0] == pytest.approx(1.0)


def test_so3_exp_inverts_so3_log_and_invert_transform_inverts():
    from graphpose.geometry import invert_transform, se3_exp, so3_exp, so3_log

    rng = np.random.default_rng(12)
    for angle in (0.0, 1e-13, 1e-6, 0.3, 2.0, np.pi - 1e-4):
        axis = rng.standard_normal(3)
        w = angle * axis / np.linalg.norm(axis)
        R = so3_exp(w)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(so3_log(R), w, atol=1e-9)
        T = se3_exp(np.r_[w, rng.standard_normal(3)])
        np.testing.assert_allclose(so3_exp(w), T[:3, :3], atol=1e-14)
        np.testing.assert_allclose(invert_transform(T) @ T, np.eye(4), atol=1e-14)


def test_hats_is_hat_of_every_column():
    from graphpose.geometry import hat, hats

    P = np.random.default_rng(2).normal(size=(3, 5))
    H = hats(P)
    assert H.shape == (5, 3, 3)
    for k in range(5):
        np.testing.assert_array_equal(H[k], hat(P[:, k]))
    assert hats(np.zeros((3, 0))).shape == (0, 3, 3)
