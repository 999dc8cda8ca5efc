"""The back end's Python factors: graphpose.track.factors."""

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import X

from graphpose import FisheyeCamera, InputError, RadTanCamera, T_from_params, project
from graphpose.geometry import to_camera
from graphpose.track.config import MotionPrior
from graphpose.track.factors import constant_velocity_factor, resection_factor
from graphpose.track.model import motion_noise
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K

POSE = T_from_params([0.22, 0.16, -0.9, 0.1, -0.05, 0.03])


def _numeric_jacobians(factor, values, keys):
    out = []
    for key in keys:
        J = np.zeros((factor.dim(), 6))
        for i in range(6):
            d = np.zeros(6)
            d[i] = 1e-6
            plus, minus = gtsam.Values(values), gtsam.Values(values)
            plus.update(key, values.atPose3(key).retract(d))
            minus.update(key, values.atPose3(key).retract(-d))
            J[:, i] = (factor.unwhitenedError(plus) - factor.unwhitenedError(minus)) / 2e-6
        out.append(J)
    return out


def test_constant_velocity_factor_is_zero_on_constant_twist_and_has_exact_jacobians():
    T0 = gtsam.Pose3(T_from_params([0.1, 0.2, -1.0, 0.1, -0.2, 0.3]))
    step = gtsam.Pose3.Expmap(np.array([0.01, -0.02, 0.015, 0.004, 0.003, -0.002]))
    values = gtsam.Values()
    for k, T in enumerate([T0, T0.compose(step), T0.compose(step).compose(step).compose(step)]):
        values.insert(X(k), T)
    # X2 is two steps after X1 while dt ratio is 2: zero error.
    noise = motion_noise(MotionPrior(huber=None))
    factor = constant_velocity_factor(X(0), X(1), X(2), 2.0, noise)
    np.testing.assert_allclose(factor.unwhitenedError(values), 0.0, atol=1e-12)
    values.update(X(2), values.atPose3(X(2)).retract(np.array([0.01, 0.0, 0.0, 0.0, 0.02, 0.0])))
    Js = _numeric_jacobians(factor, values, [X(0), X(1), X(2)])
    A, _ = factor.linearize(values).jacobian()  # whitened, columns in key order
    sigmas = noise.sigmas()
    for i, J in enumerate(Js):
        np.testing.assert_allclose(A[:, 6 * i:6 * i + 6] * sigmas[:, None], J, atol=1e-6)


def test_resection_factor_rejects():
    uv = project(K, POSE, W)
    with pytest.raises(InputError, match="same number"):
        resection_factor(X(0), uv[:, :5], W, K, 0.5)
    with pytest.raises(InputError, match="points must have shape"):
        resection_factor(X(0), uv.T, W, K, 0.5)
    with pytest.raises(InputError, match="pixel_sigma"):
        resection_factor(X(0), uv, W, K, 0.0)


@pytest.mark.parametrize("camera", [
    K,
    RadTanCamera(K, [-0.288, 0.097, 0.001, -0.0003, 0.02, 0.05, 0.01, 0.002]),
    FisheyeCamera(K, [0.03, -0.01, 0.002, -0.0005]),
], ids=["pinhole K", "rational", "fisheye"])
def test_resection_factor_error_and_jacobian_through_the_camera(camera):
    uv = project(K, POSE, W) if camera is K else camera.project(to_camera(POSE, W))
    factor = resection_factor(X(0), uv + 0.25, W, camera, 0.5)
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose3(POSE))
    np.testing.assert_allclose(factor.unwhitenedError(values), -0.25, atol=1e-9)
    A, _ = factor.linearize(values).jacobian()
    (J,) = _numeric_jacobians(factor, values, [X(0)])
    np.testing.assert_allclose(A * 0.5, J, atol=1e-5 * np.abs(J).max())
    # A pinhole factor on the same pixels sees the distortion as error.
    if camera is not K:
        assert np.abs(resection_factor(X(0), uv, W, K, 0.5).unwhitenedError(values)).max() > 1.0


@pytest.mark.parametrize("camera", [K, RadTanCamera(K, [-0.288, 0.097, 0.001, -0.0003, 0.02])],
                         ids=["pinhole K", "radial-tangential"])
def test_a_point_behind_the_camera_gives_the_constant_error_and_no_jacobian(camera):
    # The camera at the board's plane, tilted: the first rows of junctions are behind it.
    T = T_from_params([0.2, 0.16, 0.0, 0.3, 0.0, 0.0])
    behind = to_camera(T, W)[2] <= 0
    assert 0 < behind.sum() < W.shape[1]
    uv = np.full((2, W.shape[1]), 320.0)
    factor = resection_factor(X(0), uv, W, camera, 0.5)
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose3(T))
    e = factor.unwhitenedError(values).reshape(-1, 2).T
    np.testing.assert_array_equal(e[:, behind], 2.0 * K[0, 0])
    P = to_camera(T, W[:, ~behind])
    expected = (project(K, T, W[:, ~behind]) if camera is K else camera.project(P)) - uv[:, ~behind]
    np.testing.assert_allclose(e[:, ~behind], expected, rtol=1e-12, atol=1e-9)
    A, _ = factor.linearize(values).jacobian()
    rows = np.repeat(behind, 2)
    assert np.all(A[rows] == 0) and np.all(np.abs(A[~rows]).max(axis=1) > 0)
