"""graphpose.calibrate.rig_graph: solve_rig_graph, the rig calibration's GTSAM graph, on exact
projections of a known rig: from a start off it, it returns every camera, the extrinsics and
the views' poses; a view one camera missed is fine; its covariance is at the given sigma."""

import numpy as np
import pytest

from graphpose import Board, K_from_params, PinholeCamera
from graphpose.calibrate.rig_graph import RigGraph, solve_rig_graph
from graphpose.geometry import T_from_params, params_from_T, pose_difference, to_camera
from graphpose.synth.calibration import radtan_camera
from graphpose.synth.poses import random_pose

BOARD = Board()
W = BOARD.world_points()
CAMERAS = [radtan_camera(), PinholeCamera(K_from_params(545.0, 543.5, 318.0, 244.0), (640, 480))]
T_C0_C1 = T_from_params([0.12, 0.002, -0.003, 0.01, -0.03, 0.005])


def rig_problem(seed, n_views=4, missing=()):
    """Exact junctions of a two-camera rig (camera 1 misses the (view, camera) pairs in
    ``missing``), the truth, and a start off it: intrinsics 1 % off, poses and extrinsics moved."""
    rng = np.random.default_rng(seed)
    poses, observations = [], []
    for v in range(n_views):
        T = random_pose(CAMERAS[0], BOARD, rng=rng, distance=(0.5, 0.8), max_tilt_deg=40)
        poses.append(T)
        for c, T_C in enumerate([np.eye(4), T_C0_C1]):
            if (v, c) not in missing:
                observations.append((v, c, CAMERAS[c].project(to_camera(T @ T_C, W)), W))
    moved = [T_from_params(params_from_T(T) + rng.normal(0.0, [0.005] * 3 + [0.01] * 3)) for T in poses]
    starts = [c.with_parameters(c.parameters + np.r_[0.01 * c.parameters[:4], np.zeros(c.parameters.size - 4)])
              for c in CAMERAS]
    T_start = [np.eye(4), T_from_params(params_from_T(T_C0_C1) + [0.01, -0.005, 0.003, 0.01, 0.005, -0.01])]
    return (starts, T_start, moved, observations), poses


def assert_truth(result, poses):
    for camera, truth in zip(result.cameras, CAMERAS):
        assert type(camera) is type(truth)
        np.testing.assert_allclose(camera.parameters, truth.parameters, rtol=1e-7, atol=1e-9)
    np.testing.assert_array_equal(result.T_C0_C[0], np.eye(4))
    dt, dr = pose_difference(result.T_C0_C[1], T_C0_C1)
    assert dt < 1e-8 and dr < 1e-6
    for T, T_true in zip(result.poses, poses):
        dt, dr = pose_difference(T, T_true)
        assert dt < 1e-8 and dr < 1e-6


@pytest.fixture(scope="module")
def solved():
    start, poses = rig_problem(1)
    return solve_rig_graph(*start, sigma=0.1), start, poses


def test_exact_junctions_give_back_the_rig(solved):
    g, _, poses = solved
    assert isinstance(g, RigGraph) and g.converged, g.message
    assert_truth(g, poses)
    # The covariance: both cameras' intrinsics, then camera 1's six extrinsic parameters.
    n = 9 + 4 + 6
    assert g.cov.shape == (n, n)
    np.testing.assert_allclose(g.cov, g.cov.T, rtol=0, atol=1e-12 * np.abs(g.cov).max())
    assert np.all(np.linalg.eigvalsh(g.cov) > 0)


def test_the_covariance_is_at_the_given_sigma(solved):
    g, start, _ = solved
    twice = solve_rig_graph(*start, sigma=0.2)
    np.testing.assert_allclose(twice.cov, 4.0 * g.cov, rtol=1e-4, atol=1e-12 * np.abs(twice.cov).max())


def test_a_view_that_one_camera_missed_still_counts_for_the_other():
    start, poses = rig_problem(2, missing={(0, 1), (2, 1)})
    assert len(start[3]) == 6
    g = solve_rig_graph(*start, sigma=0.1)
    assert g.converged, g.message
    assert_truth(g, poses)
