"""model="rational": OpenCV's 8-coefficient model (mrcal's OPENCV8) as a calibration model: the
files that hold it and those that refuse it, and a calibration with the weak prior that holds its
near-degenerate direction (its Jacobian in the twelve parameters: tests/camera_models/test_radtan.py)."""

import numpy as np
import pytest

from graphpose import Board, InputError, read_camera, write_camera
from graphpose.calibrate import lm
from graphpose.camera_models import RationalCamera
from graphpose.geometry import to_camera
from graphpose.synth.poses import random_pose

K = [[530.0, 0.0, 322.0], [0.0, 528.0, 241.0], [0.0, 0.0, 1.0]]
D = [-0.25, 0.08, 0.001, -0.0005, 0.01, 0.05, -0.02, 0.01]


def test_files_hold_it_or_refuse_it(tmp_path):
    camera = RationalCamera(K, D, (640, 480), np.eye(12) * 1e-4)
    write_camera(tmp_path / "c.json", camera)
    back = read_camera(tmp_path / "c.json")
    assert back.model == "rational" and back == camera
    np.testing.assert_array_equal(back.covariance, camera.covariance)
    for fmt, name in (("opencv", "c.yml"), ("ros", "c.yaml")):
        write_camera(tmp_path / name, camera, format=fmt)
        assert read_camera(tmp_path / name) == camera  # 8 coefficients: the same projection
    assert "rational_polynomial" in (tmp_path / "c.yaml").read_text()
    with pytest.raises(InputError, match="Kalibr has no rational model"):
        write_camera(tmp_path / "k.yaml", camera, format="kalibr")


@pytest.mark.slow  # a whole calibration with the rational model
def test_calibration_with_the_weak_prior_converges_and_agrees():
    truth = RationalCamera(K, D, (640, 480))
    board = Board()
    W = board.world_points()
    rng = np.random.default_rng(4)
    obs, poses = [], []
    for _ in range(10):
        T = random_pose(truth, board, rng=rng, distance=(0.4, 0.8), max_tilt_deg=50)
        uv = truth.project(to_camera(T, W)) + rng.normal(0.0, 0.02, (2, W.shape[1]))
        obs.append((uv, W, np.arange(W.shape[1])))
        poses.append(T)
    start = RationalCamera(K, np.zeros(8), (640, 480))
    without = lm.solve_lm(start, poses, obs, max_iterations=3)
    with_prior = lm.solve_lm(start, poses, obs, prior_px=0.02)
    assert with_prior.converged
    # The prior pins the near-cancelling direction: the information's condition improves.
    assert np.linalg.cond(with_prior.information) < 0.1 * np.linalg.cond(without.information)
    from graphpose.calibrate.graph import solve_graph

    g = solve_graph(start, poses, obs, 0.02, prior_px=0.02)
    assert g.converged
    np.testing.assert_allclose(g.camera.parameters, with_prior.camera.parameters, rtol=1e-7, atol=1e-9)
