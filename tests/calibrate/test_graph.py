"""graphpose.calibrate.graph: solve_graph, the GTSAM graph of a calibration, on exact
projections of known cameras: it returns the truth from a start off it, holds what it is told
to hold, and its covariance scales with the pixel noise it is given."""

import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, InputError, K_from_params
from graphpose.calibrate.graph import GraphCalibration, solve_graph
from graphpose.geometry import T_from_params, params_from_T, pose_difference, to_camera
from graphpose.synth.calibration import radtan_camera
from graphpose.synth.poses import random_pose

BOARD = Board()
W = BOARD.world_points()
#: GTSAM's own Cal3Fisheye: the fast graph (the radial-tangential one runs a Python factor).
FISHEYE = FisheyeCamera(K_from_params(300.0, 302.0, 322.0, 238.0), [-0.013, -0.004, 0.0035, -0.001], (640, 480))


def problem(camera, seed, n_views=4):
    """Exact projections of the board in n_views random poses, and starts off the truth."""
    rng = np.random.default_rng(seed)
    poses, observations, starts = [], [], []
    for _ in range(n_views):
        T = random_pose(camera, BOARD, rng=rng, distance=(0.4, 0.8), max_tilt_deg=50)
        observations.append((camera.project(to_camera(T, W)), W, np.arange(W.shape[1])))
        poses.append(T)
        starts.append(T_from_params(params_from_T(T) + rng.normal(0.0, [0.005] * 3 + [0.01] * 3)))
    p = camera.parameters
    start = camera.with_parameters(p + np.r_[0.01 * p[:4], np.zeros(p.size - 4)])  # 1 % off
    return start, starts, observations, poses


@pytest.mark.parametrize("make", [radtan_camera, lambda: FISHEYE], ids=["radtan", "fisheye"])
def test_exact_projections_give_back_the_camera_and_the_poses(make):
    camera = make()
    start, starts, observations, truth = problem(camera, 1)
    g = solve_graph(start, starts, observations, 0.1)
    assert isinstance(g, GraphCalibration) and g.converged, g.message
    assert type(g.camera) is type(camera) and g.camera.size == camera.size
    np.testing.assert_allclose(g.camera.parameters, camera.parameters, rtol=1e-7, atol=1e-9)
    for T, T_true in zip(g.poses, truth):
        dt, dr = pose_difference(T, T_true)
        assert dt < 1e-8 and dr < 1e-6
    n = len(camera.parameter_names)
    assert g.cov.shape == (n, n)
    np.testing.assert_allclose(g.cov, g.cov.T, rtol=0, atol=1e-12 * np.abs(g.cov).max())
    assert np.all(np.linalg.eigvalsh(g.cov) > 0)


def test_the_covariance_is_at_the_given_pixel_noise():
    # The same solution at twice the sigma: the marginal covariance four times as large.
    start, starts, observations, _ = problem(FISHEYE, 2)
    one = solve_graph(start, starts, observations, 0.05)
    two = solve_graph(start, starts, observations, 0.1)
    np.testing.assert_allclose(two.camera.parameters, one.camera.parameters, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(two.cov, 4.0 * one.cov, rtol=1e-4, atol=1e-12 * np.abs(two.cov).max())


def test_held_parameters_stay_at_the_start_with_zero_covariance():
    # radtan4: k3 held at its start, 0.01 off the true lens's 0; the rest fit around it, so
    # the fit is not the truth, and k3 does not move.
    truth = radtan_camera()
    k3 = truth.parameter_names.index("k3")
    held = np.arange(truth.parameters.size) == k3
    camera = truth.with_parameters(np.where(held, 0.0, truth.parameters))
    start, starts, observations, _ = problem(camera, 3, n_views=3)
    g = solve_graph(start.with_parameters(np.where(held, 0.01, start.parameters)), starts, observations, 0.1,
                    held=held)
    assert g.camera.parameters[k3] == 0.01
    assert np.abs(g.camera.parameters[4] - camera.parameters[4]) > 1e-4  # k1 took up what k3 could not
    np.testing.assert_array_equal(g.cov[k3], 0.0)
    np.testing.assert_array_equal(g.cov[:, k3], 0.0)
    assert g.cov[0, 0] > 0


def test_only_radtan_parameters_can_be_held():
    start, starts, observations, _ = problem(FISHEYE, 4, n_views=3)
    with pytest.raises(InputError, match="only the radtan model's parameters can be held, not the fisheye's"):
        solve_graph(start, starts, observations, 0.1, held=np.eye(8, dtype=bool)[6])


@pytest.mark.parametrize("make", [radtan_camera, lambda: FISHEYE], ids=["radtan", "fisheye"])
def test_the_board_warp_agrees_with_the_hand_written_solver(make):
    # A bent board (mrcal's warp): GTSAM's warp variable (in the radtan factors, or in the
    # factors through GTSAM's own fisheye camera) and the hand-written solver's agree.
    from graphpose.calibrate.lm import solve_lm

    camera = make()
    rng = np.random.default_rng(7)
    warp = np.array([0.002, -0.001])
    observations, poses, bases = [], [], []
    for _ in range(5):
        T = random_pose(camera, BOARD, rng=rng, distance=(0.4, 0.8), max_tilt_deg=50)
        uv = camera.project(to_camera(T, BOARD.warped(W, warp))) + rng.normal(0.0, 0.05, (2, W.shape[1]))
        observations.append((uv, W, np.arange(W.shape[1])))
        poses.append(T)
        bases.append(BOARD.warp_basis(W))
    lm = solve_lm(camera, poses, observations, 0.07, bases=bases)
    g = solve_graph(camera, poses, observations, 0.05, 1.4, bases=bases)
    assert g.converged and lm.converged, g.message
    sd = np.sqrt(np.diag(g.cov))
    np.testing.assert_array_less(np.abs(g.camera.parameters - lm.camera.parameters), 1e-6 * sd)
    w_sd = np.sqrt(np.diag(g.warp_cov))
    np.testing.assert_array_less(np.abs(g.warp - lm.warp), 1e-6 * w_sd)
    np.testing.assert_array_less(np.abs(g.warp - warp), 4 * w_sd)
    flat = solve_graph(camera, poses, observations, 0.05, 1.4)
    assert flat.warp is None and flat.warp_cov is None
