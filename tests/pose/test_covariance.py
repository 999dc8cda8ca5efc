"""The calibration's covariance carried into the pose: derivative, Monte-Carlo, the estimate."""

import numpy as np
import pytest

from graphpose import Board, estimate_pose, estimate_pose_from_points
from graphpose.geometry import params_from_T, to_camera
from graphpose.pose.gauss_newton import gauss_newton
from graphpose.pose.covariance import (
    SIGMA_CALIBRATION,
    SIGMA_PIXEL,
    pose_cov_with_intrinsics,
    pose_intrinsics_jacobian,
)
from graphpose.synth import poses, render
from tests.conftest import LENS_CAMERAS

BOARD = Board()
W = BOARD.world_points()

#: A calibration's covariance of the radtan camera's (fx, fy, cx, cy, k1, k2, p1, p2, k3): the
#: sigmas of a good 20-view calibration, focal lengths and radial terms correlated.
SIGMAS = np.array([0.5, 0.5, 0.4, 0.4, 2e-3, 8e-3, 1e-4, 1e-4, 1e-2])
CORR = np.eye(9)
CORR[0, 1] = CORR[1, 0] = 0.9
CORR[4, 5] = CORR[5, 4] = -0.8
CORR[5, 8] = CORR[8, 5] = -0.9
CORR[4, 8] = CORR[8, 4] = 0.7
COV_K = SIGMAS[:, None] * CORR * SIGMAS[None, :]


def calibrated(camera, cov=COV_K):
    return camera.with_parameters(camera.parameters, cov)


def pose(rng, camera):
    return poses.random_pose(camera, BOARD, (640, 480), rng=rng)


@pytest.mark.parametrize("name", ["pinhole", "radtan", "fisheye"])
def test_the_pose_derivative_is_the_solved_poses_central_difference(name):
    camera = LENS_CAMERAS[name]
    rng = np.random.default_rng(1)
    T = pose(rng, camera)
    uv = camera.project(to_camera(T, W))  # exact: the minimum for the true intrinsics
    D = pose_intrinsics_jacobian(camera, T, W)
    k = camera.parameters
    steps = np.where(np.arange(k.size) < 4, 1e-3, 1e-5)
    for i, h in enumerate(steps):
        plus, minus = k.copy(), k.copy()
        plus[i] += h
        minus[i] -= h
        fits = [gauss_newton(uv, W, camera.with_parameters(p), guess=T).params for p in (plus, minus)]
        np.testing.assert_allclose(D[:, i], (fits[0] - fits[1]) / (2 * h), rtol=2e-3,
                                   atol=1e-6 * np.abs(D[:, i]).max(), err_msg=f"{name} parameter {i}")


def nees(errors, cov):
    return np.array([e @ np.linalg.solve(c, e) for e, c in zip(errors, cov)])


@pytest.mark.slow  # 1,000 full solves (Monte Carlo)
def test_monte_carlo_pose_errors_match_the_propagated_covariance():
    # Each trial: a calibration error drawn from COV_K and fresh pixel noise; the pose is
    # solved with the wrong camera, which carries COV_K. The 6-D NEES against the reported
    # covariance must be chi-square(6): mean 6.
    truth = LENS_CAMERAS["radtan"]
    rng = np.random.default_rng(7)
    T = pose(rng, truth)
    true_params = params_from_T(T)
    uv = truth.project(to_camera(T, W))
    k, L = truth.parameters, np.linalg.cholesky(COV_K)
    errors, covs, pixel_covs = [], [], []
    for _ in range(200):
        camera = truth.with_parameters(k + L @ rng.normal(size=k.size), COV_K)
        est = estimate_pose_from_points(uv + rng.normal(0.0, 0.1, uv.shape), W, camera)
        assert est.ok and est.sigma_kind == SIGMA_CALIBRATION
        errors.append(est.params - true_params)
        covs.append(est.cov)
        pixel_covs.append(est.cov_pixel)
    full, pixel = nees(errors, covs), nees(errors, pixel_covs)
    # Mean of 200 chi-square(6) draws: 6 +- 0.25 (1 sigma); measured 6.1 with 300.
    assert 5.0 < full.mean() < 7.0, full.mean()
    assert pixel.mean() > 30  # the pixel noise alone is far from the whole story here
    # Per axis: the errors' spread against the reported 1-sigma (200 trials: +-5 % at 1 sigma).
    ratio = np.std(errors, axis=0) / np.sqrt(np.mean([np.diag(c) for c in covs], axis=0))
    assert np.all((ratio > 0.8) & (ratio < 1.2)), ratio


@pytest.mark.slow  # renders and solves many calibration draws
def test_rendered_image_spread_over_calibration_draws_is_the_calibration_term():
    # One rendered raw image, its junctions extracted once; the calibration drawn again and
    # again: the pose's spread is D COV_K D^T, the difference of the two covariances.
    truth = LENS_CAMERAS["radtan"]
    rng = np.random.default_rng(11)
    T = pose(rng, truth)
    scene = render.render(truth, T, BOARD, (640, 480), noise_sigma=2.0, rng=rng)
    est0 = estimate_pose(scene.image, calibrated(truth), bounds=None, board=BOARD)
    assert est0.ok and est0.sigma_kind == SIGMA_CALIBRATION
    points, mask = est0.junctions.points, est0.junctions.trusted
    k, L = truth.parameters, np.linalg.cholesky(COV_K)
    params = []
    for _ in range(1000):  # the full solve, not its linearisation (measured: within 2 % at 2000)
        camera = truth.with_parameters(k + L @ rng.normal(size=k.size), COV_K)
        params.append(gauss_newton(points, W, camera, guess=est0.T_WC, mask=mask).params)
    spread = np.cov(np.array(params).T)
    term = est0.cov - est0.cov_pixel
    ratio = np.sqrt(np.diag(spread) / np.diag(term))
    assert np.all((ratio > 0.9) & (ratio < 1.1)), ratio  # 1000 draws: +-2.2 % at 1 sigma
    # The calibration's share dominates the position along the axis at about 1 m.
    assert est0.sigma_xyz_m[2] > 3 * np.sqrt(est0.cov_pixel[2, 2])


def test_a_camera_without_covariance_reports_pixel_noise_only():
    camera = LENS_CAMERAS["radtan"]
    rng = np.random.default_rng(2)
    T = pose(rng, camera)
    uv = camera.project(to_camera(T, W)) + rng.normal(0.0, 0.1, (2, W.shape[1]))
    plain = estimate_pose_from_points(uv, W, camera)
    assert plain.sigma_kind == SIGMA_PIXEL and plain.cov_pixel is plain.cov
    with_cov = estimate_pose_from_points(uv, W, calibrated(camera))
    np.testing.assert_array_equal(with_cov.cov_pixel, plain.cov)
    np.testing.assert_array_equal(with_cov.params, plain.params)
    extra = with_cov.cov - with_cov.cov_pixel
    assert np.linalg.eigvalsh(extra).min() > -1e-12 * np.abs(extra).max()  # D COV_K D^T: PSD
    np.testing.assert_allclose(with_cov.sigma_xyz_m, np.sqrt(np.diag(with_cov.cov)[:3]))
    # A zero covariance adds nothing.
    zero = estimate_pose_from_points(uv, W, calibrated(camera, np.zeros((9, 9))))
    np.testing.assert_allclose(zero.cov, plain.cov, rtol=1e-12, atol=0)
    assert zero.sigma_kind == SIGMA_CALIBRATION


def test_robust_fit_propagates_with_its_weights():
    camera = calibrated(LENS_CAMERAS["radtan"])
    rng = np.random.default_rng(5)
    T = pose(rng, camera)
    uv = camera.project(to_camera(T, W)) + rng.normal(0.0, 0.1, (2, W.shape[1]))
    uv[:, 7] += 3.0  # an outlier the Huber kernel down-weights
    mask = np.ones(W.shape[1], bool)
    est = estimate_pose_from_points(uv, W, camera, mask=mask, robust=True, check=False)
    from graphpose.pose.gauss_newton import huber_weights

    weights = huber_weights(est.gn.residuals, 1.345 * est.gn.sigma_px)
    assert weights[14] < 0.2 and weights[15] == weights[14]  # junction 7's u and v
    expected = pose_cov_with_intrinsics(camera, est.T_WC, W, est.cov_pixel, weights)
    np.testing.assert_allclose(est.cov, expected, rtol=1e-12)
    unweighted = pose_cov_with_intrinsics(camera, est.T_WC, W, est.cov_pixel)
    assert not np.allclose(est.cov, unweighted, rtol=1e-6)


def test_a_propagation_that_cannot_be_solved_is_nan_not_a_crash(monkeypatch):
    import graphpose.estimate as estimate_module

    camera = calibrated(LENS_CAMERAS["radtan"])
    rng = np.random.default_rng(6)
    T = pose(rng, camera)
    uv = camera.project(to_camera(T, W)) + rng.normal(0.0, 0.1, (2, W.shape[1]))

    def singular(*args, **kwargs):
        raise np.linalg.LinAlgError("Singular matrix")

    monkeypatch.setattr(estimate_module, "pose_cov_with_intrinsics", singular)
    est = estimate_pose_from_points(uv, W, camera)
    assert est.sigma_kind == SIGMA_CALIBRATION and np.all(np.isnan(est.cov))
    assert np.all(np.isfinite(est.cov_pixel))  # the pixel noise's share is still known
