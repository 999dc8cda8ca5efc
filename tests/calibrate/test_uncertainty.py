"""mrcal's projection uncertainty (graphpose.calibrate.uncertainty): the analytic derivative
of the chain unproject -> board frames -> mean back -> project against finite differences,
and its NEES against the error after mrcal's alignment on simulated calibrations."""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.calibrate import lm
from graphpose.calibrate.uncertainty import (aligned_difference, covariance_from_information, joint_information,
                                             projection_jacobian, projection_uncertainty)
from graphpose.geometry import T_from_params, params_from_T, to_camera
from graphpose.synth.calibration import fisheye_camera, radtan_camera
from graphpose.synth.poses import random_pose

NOISE_PX = 0.05
SEED = 5
TRIALS = 60


def _views(camera, n, rng):
    board = Board()
    W = board.world_points()
    obs, poses = [], []
    for _ in range(n):
        T = random_pose(camera, board, rng=rng, distance=(0.4, 0.8), max_tilt_deg=50)
        uv = camera.project(to_camera(T, W)) + rng.normal(0.0, NOISE_PX, (2, W.shape[1]))
        obs.append((uv, W, np.arange(W.shape[1])))
        poses.append(T)
    return obs, poses


def _chain(camera, poses, b, q, distance):
    """Steps 1-4 with the unknowns b perturbed: the reference the derivative must match."""
    P = camera.parameters.size
    v = camera.unproject(q)
    p = v if distance is None else v * distance
    perturbed = camera.with_parameters(b[:P])
    acc = 0.0
    for i, T in enumerate(poses):
        T2 = T_from_params(b[P + 6 * i: P + 6 * i + 6])
        if distance is None:
            acc = acc + T2[:3, :3].T @ (T[:3, :3] @ p)
        else:
            acc = acc + T2[:3, :3].T @ (T[:3, :3] @ p + T[:3, 3:4] - T2[:3, 3:4])
    return perturbed.project(acc / len(poses))


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("camera", [radtan_camera(), fisheye_camera()], ids=["radtan", "fisheye"])
@pytest.mark.parametrize("distance", [0.7, None])
def test_the_derivative_matches_finite_differences(camera, distance):
    _, poses = _views(camera, 3, np.random.default_rng(1))
    w, h = camera.size
    q = np.array([[w / 2, 10.0, w - 30.0], [h / 2, 20.0, h - 15.0]])
    J, _ = projection_jacobian(camera, poses, q, distance)
    b = np.concatenate([camera.parameters] + [params_from_T(T) for T in poses])
    step = np.where(np.arange(b.size) < 4, 1e-4, 1e-7)
    for k in range(b.size):
        db = np.zeros(b.size)
        db[k] = step[k]
        numeric = (_chain(camera, poses, b + db, q, distance) - _chain(camera, poses, b - db, q, distance)) / (2 * step[k])
        np.testing.assert_allclose(J[:, :, k], numeric.T, atol=1e-4 * max(1.0, np.max(np.abs(numeric))), err_msg=k)


@pytest.mark.slow  # whole calibrations of rendered sets
def test_nees_against_the_aligned_error_is_two():
    # One simulated geometry (exact projections), the noise drawn again and again: the grid's
    # NEES against the error after mrcal's alignment averages 2 (two coordinates), at the
    # boards' distance and at infinity.
    camera = radtan_camera()
    rng = np.random.default_rng(SEED)
    w, h = camera.size
    u, v = np.meshgrid(np.linspace(40, w - 40, 5), np.linspace(40, h - 40, 4))
    q = np.stack([u.ravel(), v.ravel()])
    P = camera.parameters.size
    obs, poses = _views(camera, 8, rng)
    exact = [(camera.project(to_camera(T, W)), W, i) for T, (_, W, i) in zip(poses, obs)]
    values = {0.6: [], None: []}
    for _ in range(TRIALS):
        noisy = [(uv + rng.normal(0.0, NOISE_PX, uv.shape), W, i) for uv, W, i in exact]
        fit = lm.solve_lm(camera, poses, noisy)
        r = np.hstack(fit.residuals)
        sigma = np.sqrt(np.sum(r * r) / (r.size - P - 6 * len(poses)))
        C = covariance_from_information(joint_information(fit.camera, fit.poses, noisy), sigma)
        for d in values:
            U = projection_uncertainty(fit.camera, fit.poses, C, q, d)
            e = aligned_difference(fit.camera, fit.poses, camera, poses, q, d).T
            values[d].append(np.mean(np.einsum("ni,nij,nj->n", e, np.linalg.inv(U.cov), e)))
    for d, nees in values.items():
        assert 1.4 < np.mean(nees) < 2.8, (d, nees)


def test_bad_distance_and_shape():
    camera = radtan_camera()
    obs, poses = _views(camera, 3, np.random.default_rng(2))
    C = np.eye(9 + 18)
    with pytest.raises(InputError, match="distance_m"):
        projection_uncertainty(camera, poses, C, [[1.0], [2.0]], -1.0)
    with pytest.raises(InputError, match="joint_cov"):
        projection_uncertainty(camera, poses, np.eye(5), [[1.0], [2.0]])
