"""graphpose.pose.rig: the rig's points and their derivatives, each camera weighed by its own noise
(estimate_rig_pose on rendered rig frames is tested in tests/test_pipeline_rig.py)."""

import numpy as np
import pytest

from graphpose.geometry import T_from_params
from graphpose.pose.rig import rig_points


def test_rig_points_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    W = rng.uniform(-0.3, 0.3, (3, 5))
    q = np.array([0.1, -0.2, -1.5, 0.3, -0.2, 0.5])
    e = np.array([0.2, 0.01, -0.03, 0.05, 0.1, -0.2])
    p, Jq, Je = rig_points(q, W, e=e)
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-6
        num_q = (rig_points(q + d, W, e=e)[0] - rig_points(q - d, W, e=e)[0]) / 2e-6
        num_e = (rig_points(q, W, e=e + d)[0] - rig_points(q, W, e=e - d)[0]) / 2e-6
        assert np.allclose(Jq[:, :, k].T, num_q, atol=1e-8) and np.allclose(Je[:, :, k].T, num_e, atol=1e-8)
    # With the extrinsics as a matrix, the same points.
    assert np.allclose(rig_points(q, W, T_from_params(e))[0], p, atol=1e-14)


@pytest.mark.slow  # 20 poses solved by both solvers: a few seconds under load
def test_each_camera_is_weighed_by_its_own_noise():
    # Exact junctions of a stereo pair, camera 1's ten times noisier than camera 0's: each
    # camera's noise is found from its residuals, the pose is as good as the bound with the
    # true weights (far better than with both cameras weighed alike), and its covariance
    # holds (NEES about 6).
    from graphpose import Board
    from graphpose.geometry import params_from_T, to_camera
    from graphpose.pose.rig import estimate_rig_pose_from_points
    from graphpose.rig import Rig
    from graphpose.synth.calibration import radtan_camera
    from graphpose.synth.poses import random_pose

    board = Board(9, 6, 0.06)
    W = board.world_points()
    camera = radtan_camera()
    rig = Rig([camera, camera], [np.eye(4), T_from_params([0.15, 0.0, 0.0, 0.0, -0.1, 0.0])])
    rng = np.random.default_rng(29)
    noise = np.array([0.02, 0.2])
    found, errors, nees, bound, alike = [], [], [], [], []
    for _ in range(20):
        T = random_pose(camera, board, rng=rng, distance=(0.6, 0.9), max_tilt_deg=30)
        q = params_from_T(T)
        obs, J = [], []
        for c in range(2):
            p, Jq, _ = rig_points(q, W, rig.T_C0_C[c])
            uv, G = camera.project_jacobian(p)
            obs.append((uv + rng.normal(0.0, noise[c], uv.shape), W))
            J.append((G @ Jq).reshape(-1, 6))
        est = estimate_rig_pose_from_points(rig, obs, board)
        assert est.ok, est.message
        e = est.params - q
        found.append(est.camera_sigma_px)
        errors.append(e[:3] @ e[:3])
        nees.append(e @ np.linalg.solve(est.cov, e))
        H = [Jc.T @ Jc for Jc in J]
        bound.append(np.trace(np.linalg.inv(H[0] / noise[0] ** 2 + H[1] / noise[1] ** 2)[:3, :3]))
        Hi = np.linalg.inv(H[0] + H[1])  # both alike: the sandwich of the unweighted fit
        alike.append(np.trace((Hi @ (H[0] * noise[0] ** 2 + H[1] * noise[1] ** 2) @ Hi)[:3, :3]))
    np.testing.assert_allclose(np.mean(found, axis=0), noise, rtol=0.1)
    assert np.mean(errors) < 1.3 * np.mean(bound) < 0.5 * np.mean(alike)  # 1.04 and 0.04 here
    assert 4.0 < np.mean(nees) < 8.5
