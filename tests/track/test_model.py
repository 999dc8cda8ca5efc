"""graphpose.track.model: the tracker's keys, noise models and factors (FactorBuilder), and
what a frame gave the back end (FrameMeasurement)."""

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import L, V, X

from graphpose import Board, InputError, PinholeCamera, project
from graphpose.track.config import MotionPrior
from graphpose.track.model import FactorBuilder, landmark_stride, motion_noise
from graphpose.track.sequence_graph import SequenceGraph
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K
from tests.helpers import wavy_trajectory

BOARD = Board()
ALL = np.arange(BOARD.n)


def test_motion_noise_is_rotation_then_translation_and_robust_when_asked():
    prior = MotionPrior(sigma_rot_rad=0.002, sigma_trans_m=0.0003, huber=None)
    np.testing.assert_array_equal(motion_noise(prior).sigmas(), prior.sigmas())
    robust = motion_noise(MotionPrior(huber=2.0))
    assert isinstance(robust, gtsam.noiseModel.Robust)
    assert not isinstance(motion_noise(prior), gtsam.noiseModel.Robust)


def test_backend_frame_landmark_keys_are_distinct():
    board = Board(20, 10)
    assert landmark_stride(board) == 1000 and landmark_stride(BOARD) == 100
    graph = SequenceGraph(K, board, MotionPrior(), target="frame_landmarks")
    keys = {graph.landmark_key(k, j) for k in range(30) for j in range(200)}
    assert len(keys) == 30 * 200
    assert gtsam.Symbol(graph.landmark_key(300, 3)).string() == "l300003"
    with pytest.raises(InputError, match="target must be one of"):
        SequenceGraph(K, BOARD, MotionPrior(), target="points")


def _builder(target, model="constant_velocity"):
    return FactorBuilder(PinholeCamera(K), board=BOARD, motion=MotionPrior(model), target=target,
                         landmark_sigma_m=1e-8)


def _frame(builder, k, T, ids=ALL, t=None):
    return builder.frame(k, k / 30.0 if t is None else t, project(K, T, W[:, ids]), ids, T, 0.1)


@pytest.mark.parametrize("target, per_frame, new_values", [
    ("resection", 1, 1),                                # one factor holding every junction; X(k)
    ("frame_landmarks", 2 * BOARD.n, BOARD.n + 1),      # a prior and a projection per junction
    ("landmarks", BOARD.n, 1),                          # a projection per junction on the shared L(j)
])
def test_each_target_form_adds_its_factors_and_values(target, per_frame, new_values):
    _, poses = wavy_trajectory(3)
    builder = _builder(target)
    sizes = []
    for k in range(3):
        graph, values, stamps = _frame(builder, k, poses[k])
        sizes.append(graph.size())
        assert values.size() == new_values and values.exists(X(k))
        assert set(stamps) == set(values.keys()) and set(stamps.values()) == {k / 30.0}
        np.testing.assert_allclose(values.atPose3(X(k)).matrix(), poses[k], atol=1e-15)
    # Constant velocity needs the two frames before: frames 0 and 1 have no motion factor.
    assert sizes == [per_frame, per_frame, per_frame + 1]


def test_frame_landmarks_are_pinned_copies_with_the_frames_keys():
    _, poses = wavy_trajectory(1)
    builder = _builder("frame_landmarks")
    _, values, _ = _frame(builder, 7, poses[0], ids=ALL[:5])
    for j in range(5):
        np.testing.assert_array_equal(values.atPoint3(builder.landmark_key(7, j)), W[:, j])
    assert gtsam.Symbol(builder.landmark_key(7, 3)).string() == "l703"


def test_the_shared_landmarks_are_every_target_point_once():
    graph, values = _builder("landmarks").shared_landmarks()
    assert graph.size() == values.size() == BOARD.n
    np.testing.assert_array_equal(values.atPoint3(L(47)), W[:, 47])


@pytest.mark.parametrize("target", ["resection", "frame_landmarks"])
def test_exact_measurements_cost_nothing_at_the_true_poses(target):
    _, poses = wavy_trajectory(3)
    builder = _builder(target, "random_walk")
    whole, truth = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for k in range(3):
        graph, values, _ = _frame(builder, k, poses[k])
        whole.push_back(graph)
        truth.insert(values)
    # The random walk pulls consecutive poses together, so its part is not zero: only the
    # target factors are exact (1e-18: rounding of the projections, squared).
    target_error = sum(whole.at(i).error(truth) for i in range(whole.size())
                       if not isinstance(whole.at(i), gtsam.BetweenFactorPose3))
    assert target_error < 1e-18
    assert sum(isinstance(whole.at(i), gtsam.BetweenFactorPose3) for i in range(whole.size())) == 2


def test_wnoa_gives_a_segment_its_velocities_with_its_first_factor():
    _, poses = wavy_trajectory(3)
    builder = _builder("resection", "wnoa")
    _, first, _ = _frame(builder, 0, poses[0])
    assert not first.exists(V(0))  # a one-frame segment has no velocity: it stays determined
    graph, second, stamps = _frame(builder, 1, poses[1])
    assert second.exists(V(0)) and second.exists(V(1)) and graph.size() == 2
    assert stamps[V(0)] == 0.0 and stamps[V(1)] == 1 / 30.0
    np.testing.assert_array_equal(second.atVector(V(1)), np.zeros(6))
    _, third, _ = _frame(builder, 2, poses[2])
    assert not third.exists(V(1)) and third.exists(V(2))


def test_a_broken_or_forgotten_segment_adds_no_motion_factor():
    _, poses = wavy_trajectory(4)
    builder = _builder("resection", "random_walk")
    _frame(builder, 0, poses[0])
    builder.break_segment()
    assert _frame(builder, 1, poses[1])[0].size() == 1
    assert _frame(builder, 2, poses[2])[0].size() == 2
    builder.forget_before(10.0)  # every frame so far is older than 10 s: marginalised
    assert builder.segment == []
    assert _frame(builder, 3, poses[3])[0].size() == 1


def test_an_unknown_target_form_is_refused():
    with pytest.raises(InputError, match="target must be one of"):
        _builder("points")
