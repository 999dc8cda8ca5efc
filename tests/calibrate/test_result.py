"""graphpose.calibrate.result: the Calibration record's own arithmetic, on a record made by hand
(a pinhole camera whose projection derivative is written down): sigmas, the uncertainty map,
the coverage grid, and what a failed calibration refuses."""

import numpy as np
import pytest

from graphpose import InputError, K_from_params, PinholeCamera
from graphpose.calibrate.result import STATUSES, Calibration, SolverCrossCheck

FX, FY, CX, CY = 500.0, 480.0, 319.5, 239.5
CAMERA = PinholeCamera(K_from_params(FX, FY, CX, CY), (640, 480))
SIGMAS = np.array([2.0, 3.0, 1.5, 0.5])  # fx, fy, cx, cy, pixels


def calibration(points, status, cov=np.diag(SIGMAS ** 2), joint_cov=None):
    n = len(points)
    check = SolverCrossCheck(gtsam=list(CAMERA.parameters), lm=list(CAMERA.parameters), max_difference=0.0,
                             tolerance=1e-6, gtsam_converged=True, lm_converged=True)
    return Calibration(camera=CAMERA, cov=cov, parameter_names=CAMERA.parameter_names,
                       images=tuple(f"image {i}" for i in range(n)), status=tuple(status),
                       message=("",) * n, poses=(None,) * n, image_rms_px=np.zeros(n), points=tuple(points),
                       residuals=tuple(np.zeros_like(p) for p in points), rms_px=0.0, sigma_px=0.1, ok=True,
                       cross_check=check, summary="made by hand", joint_cov=joint_cov)


def test_parameters_and_sigmas_are_the_cameras_and_the_covariance_diagonal():
    c = calibration([np.zeros((2, 0))], ["no board"])
    np.testing.assert_array_equal(c.parameters, [FX, FY, CX, CY])
    np.testing.assert_allclose(c.sigmas, SIGMAS, rtol=1e-15)
    assert set(c.status) <= set(STATUSES)


def test_uncertainty_map_of_a_pinhole_is_its_written_down_derivative():
    # u = fx x + cx, v = fy y + cy: with a diagonal covariance the pixel covariance is
    # diag(x^2 s_fx^2 + s_cx^2, y^2 s_fy^2 + s_cy^2); its larger eigenvalue's root is the map.
    c = calibration([np.zeros((2, 0))], ["no board"])
    us, vs, sigma = c.uncertainty_map(step=40.0)
    np.testing.assert_array_equal(us, np.arange(0.0, 640.0, 40.0))
    np.testing.assert_array_equal(vs, np.arange(0.0, 480.0, 40.0))
    x, y = np.meshgrid((us - CX) / FX, (vs - CY) / FY)
    expected = np.sqrt(np.maximum(x ** 2 * SIGMAS[0] ** 2 + SIGMAS[2] ** 2, y ** 2 * SIGMAS[1] ** 2 + SIGMAS[3] ** 2))
    np.testing.assert_allclose(sigma, expected, rtol=1e-12)
    # A correlated covariance: the map is the 2 x 2 matrix's largest eigenvalue, computed here.
    rng = np.random.default_rng(1)
    A = rng.normal(size=(4, 4))
    cov = A @ A.T
    c = calibration([np.zeros((2, 0))], ["no board"], cov=cov)
    us, vs, sigma = c.uncertainty_map(step=100.0)
    for i, v in enumerate(vs):
        for j, u in enumerate(us):
            x, y = (u - CX) / FX, (v - CY) / FY
            J = np.array([[x, 0.0, 1.0, 0.0], [0.0, y, 0.0, 1.0]])
            assert sigma[i, j] == pytest.approx(np.sqrt(np.linalg.eigvalsh(J @ cov @ J.T).max()), rel=1e-10)


def test_coverage_counts_the_used_images_junctions_per_cell():
    used = np.array([[0.0, 10.0, 99.0, 100.0, 639.0], [0.0, 5.0, 50.0, 150.0, 479.0]])
    rejected = np.array([[10.0], [10.0]])  # not counted: only used images are
    c = calibration([used, rejected, np.zeros((2, 0))], ["used", "rejected", "no board"])
    us, vs, counts = c.coverage(step=100.0)
    assert counts.shape == (vs.size, us.size) == (5, 7)
    expected = np.zeros((5, 7), dtype=int)
    # Cells [u - 0.5, u - 0.5 + 100): u = 99 is in the first column, u = 100 in the second.
    expected[0, 0] = 3  # (0, 0), (10, 5), (99, 50)
    expected[1, 1] = 1  # (100, 150)
    expected[4, 6] = 1  # (639, 479)
    np.testing.assert_array_equal(counts, expected)


def test_a_failed_calibration_has_no_projection_uncertainty():
    c = calibration([np.zeros((2, 0))], ["no board"])
    with pytest.raises(InputError, match="no joint covariance"):
        c.projection_uncertainty([[320.0], [240.0]])
    with pytest.raises(InputError, match="no joint covariance"):
        calibration([np.zeros((2, 0))], ["no board"], joint_cov=np.full((4, 4), np.nan)).projection_uncertainty(
            [[320.0], [240.0]])
    with pytest.raises(InputError, match="distance_m must be metres, 'boards' or None, got 'far'"):
        c.projection_uncertainty_map(distance_m="far")
    with pytest.raises(InputError, match="step"):
        c.uncertainty_map(step=0.5)
