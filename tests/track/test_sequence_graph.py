"""The whole-sequence back end, graphpose.track.sequence_graph (SequenceGraph): exact poses,
its three target forms, smoothing, segments and lenses."""

import gtsam
import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, RadTanCamera, project
from graphpose.geometry import to_camera
from graphpose.track.config import MotionPrior
from graphpose.track.sequence_graph import SequenceGraph
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K
from tests.helpers import wavy_trajectory

BOARD = Board()
ALL = np.arange(BOARD.n)


@pytest.mark.parametrize("target, model", [("resection", "constant_velocity"), ("landmarks", "constant_velocity"),
                                           ("frame_landmarks", "constant_velocity"), ("resection", "wnoa")])
def test_backend_recovers_exact_poses(target, model):
    t, poses = wavy_trajectory(8)
    graph = SequenceGraph(K, BOARD, MotionPrior(model, 1.0, 1.0), target=target)  # no pull
    rng = np.random.default_rng(1)
    for k in range(8):
        start = poses[k] @ gtsam.Pose3.Expmap(rng.normal(0, 0.01, 6)).matrix()
        result = graph.add_frame(k, t[k], project(K, poses[k], W), ALL, start, 0.05)
        np.testing.assert_allclose(result.T_WC, poses[k], atol=1e-6)
        assert np.all(np.linalg.eigvalsh(result.cov) > 0)
    assert graph.frames == list(range(8))
    smoothed = graph.smooth()
    for k in range(8):
        np.testing.assert_allclose(smoothed[k].T_WC, poses[k], atol=1e-7)
        np.testing.assert_allclose(graph.estimate()[k], poses[k], atol=1e-6)


@pytest.mark.slow  # 1.0 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("model", ["constant_velocity", "random_walk", "wnoa"])
def test_backend_target_forms_agree_on_noisy_correspondences(model):
    # The three forms minimise the same cost (up to the 1e-8 m landmark pins): online and
    # smoothed poses must agree far below the noise. The start is the true pose, so the
    # motion prior moves the new pose by microns: an iSAM2 that never relinearised it (a
    # landmark at the root of the Bayes tree) stayed ~8 um off.
    n = 20
    t, poses = wavy_trajectory(n)
    rng = np.random.default_rng(3)
    uvs = [project(K, T, W) + rng.normal(0, 0.1, (2, BOARD.n)) for T in poses]
    ids_of = [ALL if k % 5 else ALL[k % 7:] for k in range(n)]  # some frames see fewer junctions
    out = {}
    for target in ("resection", "landmarks", "frame_landmarks"):
        graph = SequenceGraph(K, BOARD, MotionPrior(model), target=target)
        online = []
        for k in range(n):
            if k in (12, 13):  # frame 12 alone: a segment without motion factor (nor velocity)
                graph.break_segment()
            online.append(graph.add_frame(k, t[k], uvs[k][:, ids_of[k]], ids_of[k], poses[k], 0.1).T_WC)
        smoothed = graph.smooth()
        out[target] = np.array(online), np.array([smoothed[k].T_WC for k in range(n)])
    ref_online, ref_smoothed = out["resection"]
    assert np.max(np.abs(ref_smoothed[:, :3, 3] - poses[:, :3, 3])) > 1e-5  # the noise shows
    # Online estimates are iSAM2's, linearised lazily: the Huber-robust random walk, in its
    # linear regime on this motion, reweights with the stale linearisation points, and each
    # form's iSAM2 is a few microns off its own filtered optimum (all of them, resection too);
    # the velocities of "wnoa" start at zero and are relinearised as lazily.
    online_atol = {"constant_velocity": 1e-6, "random_walk": 5e-5, "wnoa": 1e-5}[model]
    for target in ("landmarks", "frame_landmarks"):
        online, smoothed = out[target]
        np.testing.assert_allclose(online, ref_online, atol=online_atol, err_msg=target)
        np.testing.assert_allclose(smoothed, ref_smoothed, atol=1e-7, err_msg=target)


@pytest.mark.slow  # 90 frames online and smoothed, beside 90 single-frame solves
def test_backend_smoothing_beats_single_frames_on_noisy_correspondences():
    n = 90
    t, poses = wavy_trajectory(n)
    rng = np.random.default_rng(2)
    graph = SequenceGraph(K, BOARD, MotionPrior())
    single, online = [], []
    for k in range(n):
        uv = project(K, poses[k], W) + rng.normal(0, 0.2, (2, BOARD.n))
        lone = SequenceGraph(K, BOARD, MotionPrior()).add_frame(0, 0.0, uv, ALL, poses[k], 0.2)
        single.append(lone.T_WC)
        online.append(graph.add_frame(k, t[k], uv, ALL, lone.T_WC, 0.2).T_WC)
    smoothed = [graph.smooth()[k].T_WC for k in range(n)]

    def rmse(estimates):
        return np.sqrt(np.mean([np.sum((E[:3, 3] - T[:3, 3]) ** 2) for E, T in zip(estimates, poses)]))

    assert rmse(smoothed) < rmse(online) < rmse(single)
    assert rmse(smoothed) < 0.7 * rmse(single)


def test_backend_segments_after_a_break_have_no_motion_factor():
    t, poses = wavy_trajectory(6)
    graph = SequenceGraph(K, BOARD, MotionPrior("random_walk", 1e-9, 1e-9))
    graph.add_frame(0, t[0], project(K, poses[0], W), ALL, poses[0], 0.1)
    graph.break_segment()
    # A random walk this tight would drag frame 5 onto frame 0 if the two were linked.
    result = graph.add_frame(5, t[5], project(K, poses[5], W), ALL, poses[5], 0.1)
    np.testing.assert_allclose(result.T_WC, poses[5], atol=1e-7)


@pytest.mark.slow  # three lenses x three target forms over a sequence
@pytest.mark.parametrize("camera", [
    RadTanCamera(K, [-0.288, 0.097, 0.001, -0.0003]),                       # GTSAM's Cal3DS2
    RadTanCamera(K, [-0.25, 0.08, 0.001, -0.0003, 0.02, 0.05, 0.01, 0.002]),  # a custom factor
    FisheyeCamera(K, [0.03, -0.01, 0.002, -0.0005]),                         # GTSAM's Cal3Fisheye
], ids=["radtan", "rational", "fisheye"])
def test_backend_target_forms_project_through_the_lens(camera):
    t, poses = wavy_trajectory(6)
    rng = np.random.default_rng(4)
    uvs = [camera.project(to_camera(T, W)) for T in poses]
    for target in ("resection", "landmarks", "frame_landmarks"):
        graph = SequenceGraph(camera, BOARD, MotionPrior("constant_velocity", 1.0, 1.0), target=target)
        for k in range(6):
            start = poses[k] @ gtsam.Pose3.Expmap(rng.normal(0, 0.01, 6)).matrix()
            np.testing.assert_allclose(graph.add_frame(k, t[k], uvs[k], ALL, start, 0.05).T_WC, poses[k],
                                       atol=1e-6, err_msg=target)
