"""graphpose.track.smoothing: batch smoothing of a whole sequence, from its measurements or its
graph, and GTSAM's answer turned into a BackendResult."""

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import X

from graphpose import Board, project
from graphpose.geometry import T_from_params, params_from_T
from graphpose.track.config import MotionPrior
from graphpose.track.model import FrameMeasurement
from graphpose.track.results import BackendResult
from graphpose.track.smoothing import backend_result, smooth_frames, smooth_graph
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K
from tests.helpers import wavy_trajectory

BOARD = Board()
ALL = np.arange(BOARD.n)


def _tangent_jacobian(T, h=1e-6):
    """d params / d xi at xi = 0 for T @ Expmap(xi), xi = (omega, v): a central difference."""
    J = np.zeros((6, 6))
    for i in range(6):
        xi = np.zeros(6)
        xi[i] = h
        plus = params_from_T(T @ gtsam.Pose3.Expmap(xi).matrix())
        minus = params_from_T(T @ gtsam.Pose3.Expmap(-xi).matrix())
        J[:, i] = (plus - minus) / (2 * h)
    return J


def test_backend_result_carries_the_tangent_covariance_into_the_pose_parameters():
    T = T_from_params([0.2, -0.1, -0.9, 0.3, -0.2, 0.5])
    A = np.random.default_rng(2).normal(size=(6, 6))
    cov_tangent = A @ A.T * 1e-4
    result = backend_result(T, cov_tangent, 0.25)
    assert isinstance(result, BackendResult) and result.update_s == 0.25
    np.testing.assert_array_equal(result.T_WC, T)
    J = _tangent_jacobian(T)
    np.testing.assert_allclose(result.cov, J @ cov_tangent @ J.T, rtol=1e-6, atol=1e-14)


def test_smooth_graph_gives_the_optimum_and_its_marginals():
    # Two poses, each with a prior, and a between factor that disagrees: the optimum is the
    # sigma-weighted compromise, and each marginal is the information's inverse (all linear here,
    # in translation only).
    a, b = T_from_params([0.0, 0.0, -1.0, 0, 0, 0]), T_from_params([0.1, 0.0, -1.0, 0, 0, 0])
    prior = gtsam.noiseModel.Isotropic.Sigma(6, 0.01)
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose3(X(0), gtsam.Pose3(a), prior))
    graph.add(gtsam.PriorFactorPose3(X(1), gtsam.Pose3(b), prior))
    graph.add(gtsam.BetweenFactorPose3(X(0), X(1), gtsam.Pose3(T_from_params([0.13, 0, 0, 0, 0, 0])), prior))
    initial = gtsam.Values()
    initial.insert(X(0), gtsam.Pose3(T_from_params([0.05, 0.02, -1.1, 0.1, 0, 0])))
    initial.insert(X(1), gtsam.Pose3(b))
    out = smooth_graph(graph, initial, [1, 0])
    assert list(out) == [1, 0]
    # x0, x1 minimising x0^2 + (x1 - 0.1)^2 + (x1 - x0 - 0.13)^2: 2 x0 - x1 = -0.13 and
    # 2 x1 - x0 = 0.23, so x0 = -0.01, x1 = 0.11.
    np.testing.assert_allclose(out[0].T_WC[:3, 3], [-0.01, 0.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(out[1].T_WC[:3, 3], [0.11, 0.0, -1.0], atol=1e-9)
    # Information per coordinate [[2, -1], [-1, 2]] / sigma^2: a marginal variance of 2/3 sigma^2
    # for x and roll (the between factor's 0.11 m lever arm along x couples the other rotations
    # with the translations a little: those are within 1 %).
    np.testing.assert_allclose(np.diag(out[0].cov)[[0, 3]], 2 / 3 * 1e-4, rtol=1e-6)
    np.testing.assert_allclose(np.diag(out[0].cov), 2 / 3 * 1e-4, rtol=0.01)
    assert out[0].update_s == 0.0


@pytest.mark.parametrize("target", ["resection", "landmarks"])
def test_smooth_frames_rebuilds_the_sequence_and_recovers_exact_poses(target):
    t, poses = wavy_trajectory(5)
    measurements = [FrameMeasurement(k, t[k], project(K, poses[k], W), ALL, 0.2, k in (0, 3)) for k in range(5)]
    rng = np.random.default_rng(6)
    initial = {k: poses[k] @ gtsam.Pose3.Expmap(rng.normal(0, 0.01, 6)).matrix() for k in range(5)}
    # A loose motion prior: the exact projections alone fix every pose.
    out = smooth_frames(K, BOARD, MotionPrior("constant_velocity", 1.0, 1.0), target, measurements, initial)
    assert sorted(out) == list(range(5))
    for k in range(5):
        np.testing.assert_allclose(out[k].T_WC, poses[k], atol=1e-7)
        assert np.all(np.linalg.eigvalsh(out[k].cov) > 0)
    # Fewer pixels' worth of information, a larger covariance: sigma 0.4 px quadruples it.
    noisier = [FrameMeasurement(m.index, m.timestamp, m.points, m.ids, 0.4, m.new_segment) for m in measurements]
    wide = smooth_frames(K, BOARD, MotionPrior("constant_velocity", 1.0, 1.0), target, noisier, initial)
    assert np.trace(wide[2].cov) > 2.0 * np.trace(out[2].cov)
