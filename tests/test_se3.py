"""The SE(3) toolkit of graphpose.geometry against GTSAM's Pose3 (the twist order it follows)."""

import gtsam
import numpy as np
import pytest

from graphpose.geometry import T_from_params, hat, pose_difference, relative_pose, se3_exp, se3_log, so3_log


def _twists():
    rng = np.random.default_rng(7)
    out = [np.zeros(6), np.r_[1e-9, -2e-9, 3e-9, 0.1, 0.2, -0.3], np.r_[3e-5, 0.0, -1e-5, 1.0, -2.0, 0.5]]
    for scale in (0.01, 0.5, 1.5):
        out += [np.r_[scale * rng.normal(size=3), rng.normal(size=3)] for _ in range(4)]
    axis = np.array([0.6, -0.8, 0.0])
    out += [np.r_[(np.pi - 1e-5) * axis, 0.2, 0.1, -0.4], np.r_[(np.pi - 3e-4) * axis[::-1], 1.0, 0.0, 0.0]]
    return out


@pytest.mark.parametrize("xi", _twists())
def test_exp_and_log_are_gtsam_pose3(xi):
    T = se3_exp(xi)
    np.testing.assert_allclose(T, gtsam.Pose3.Expmap(xi).matrix(), rtol=0, atol=1e-12)
    # Within 1e-3 rad of a half turn GTSAM's own log is good to a few 1e-9 only (ours to the
    # round trip's 1e-12, checked below).
    near_pi = np.pi - np.linalg.norm(xi[:3]) < 1e-3
    np.testing.assert_allclose(se3_log(T), gtsam.Pose3.Logmap(gtsam.Pose3(T)), rtol=0,
                               atol=1e-8 if near_pi else 1e-11)
    if np.linalg.norm(xi[:3]) < np.pi:  # the log's answer is the twist of angle below pi
        np.testing.assert_allclose(se3_log(T), xi, rtol=0, atol=1e-11)


def test_log_of_random_poses_round_trips():
    rng = np.random.default_rng(3)
    for _ in range(20):
        T = T_from_params(np.r_[rng.normal(size=3), rng.uniform(-3, 3, size=3)])
        np.testing.assert_allclose(se3_exp(se3_log(T)), T, rtol=0, atol=1e-12)
        np.testing.assert_allclose(se3_log(T), gtsam.Pose3.Logmap(gtsam.Pose3(T)), rtol=0, atol=1e-10)


def test_so3_log_at_a_half_turn_gives_the_axis():
    axis = np.array([0.0, 0.6, 0.8])
    R = se3_exp(np.r_[np.pi * axis, 0.0, 0.0, 0.0])[:3, :3]
    w = so3_log(R)
    assert np.linalg.norm(w) == pytest.approx(np.pi, abs=1e-12)
    np.testing.assert_allclose(np.abs(w / np.pi), axis, atol=1e-7)


def test_hat_is_the_cross_product():
    w, p = np.array([0.3, -1.2, 2.0]), np.array([-0.5, 0.7, 4.0])
    np.testing.assert_allclose(hat(w) @ p, np.cross(w, p), atol=1e-15)
    np.testing.assert_array_equal(hat(w), -hat(w).T)


def test_relative_pose_and_difference():
    A = T_from_params([0.1, -0.2, -1.0, 0.3, -0.1, 2.0])
    B = T_from_params([0.2, 0.0, -0.9, 0.25, -0.05, 2.1])
    np.testing.assert_allclose(relative_pose(A, B), np.linalg.inv(A) @ B, atol=1e-12)
    np.testing.assert_allclose(relative_pose(A, B), gtsam.Pose3(A).between(gtsam.Pose3(B)).matrix(), atol=1e-12)
    dt, dr = pose_difference(A, B)
    assert dt == pytest.approx(np.linalg.norm(A[:3, 3] - B[:3, 3]), abs=1e-15)
    angle = np.degrees(np.linalg.norm(so3_log(relative_pose(A, B)[:3, :3])))
    assert dr == pytest.approx(angle, abs=1e-10)
    assert pose_difference(A, A) == (0.0, 0.0)
