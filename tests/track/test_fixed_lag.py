"""graphpose.track.fixed_lag: the online back end over the last lag_s seconds, held against the
whole-sequence graph (graphpose.track.sequence_graph), which it must match up to the
linearisation frozen in its marginal priors."""

import numpy as np
import pytest

from graphpose import Board, InputError, project
from graphpose.track.backend import make_backend
from graphpose.track.config import MotionPrior
from graphpose.track.fixed_lag import FixedLagGraph
from graphpose.track.sequence_graph import SequenceGraph
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K
from tests.helpers import wavy_trajectory

BOARD = Board()
ALL = np.arange(BOARD.n)


def _noisy_run(graph, n, uvs, t, poses, breaks=(50,)):
    online = []
    for k in range(n):
        if k in breaks:
            graph.break_segment()
        online.append(graph.add_frame(k, t[k], uvs[k], ALL, poses[k], 0.1).T_WC)
    return np.array(online)


@pytest.mark.slow  # 120 frames through both back ends, nine form x motion pairs
@pytest.mark.parametrize("target", ["resection", "frame_landmarks", "landmarks"])
@pytest.mark.parametrize("model", ["constant_velocity", "random_walk", "wnoa"])
def test_fixed_lag_matches_the_whole_sequence_graph(model, target):
    # Regression guards, from an earlier run of this test. A lag of 0.3 s (9 frames) over 120
    # frames: most frames are marginalised. The online
    # poses differ only by the linearisation frozen in the marginal priors: measured at most
    # 0.53 um (constant velocity), 0.02 um (wnoa), and 96 um for the Huber-robust random walk,
    # which on this motion is in its linear regime and reweights lazily (the whole-sequence
    # iSAM2 itself is 17 um off its own filtered optimum there). The noise moves the poses by
    # about 2 mm. Batch smoothing rebuilds the same graph: measured within 0.11 um.
    n = 120
    t, poses = wavy_trajectory(n)
    rng = np.random.default_rng(3)
    uvs = [project(K, T, W) + rng.normal(0, 0.1, (2, BOARD.n)) for T in poses]
    full = SequenceGraph(K, BOARD, MotionPrior(model), target=target)
    lag = FixedLagGraph(K, BOARD, MotionPrior(model), target=target, lag_s=0.3)
    full_online, lag_online = _noisy_run(full, n, uvs, t, poses), _noisy_run(lag, n, uvs, t, poses)
    assert lag.frames == full.frames == list(range(n))
    assert len(lag.estimate()) < 12 < n  # only the lag's frames are left
    assert np.max(np.abs(full_online[:, :3, 3] - poses[:, :3, 3])) > 1e-3  # the noise shows
    online_atol = {"constant_velocity": 2e-6, "random_walk": 2e-4, "wnoa": 1e-7}[model]
    np.testing.assert_allclose(lag_online, full_online, atol=online_atol)
    full_smoothed, lag_smoothed = full.smooth(), lag.smooth()
    for k in range(n):
        np.testing.assert_allclose(lag_smoothed[k].T_WC, full_smoothed[k].T_WC, atol=1e-6)
        np.testing.assert_allclose(lag_smoothed[k].cov, full_smoothed[k].cov, rtol=1e-4, atol=1e-16)


@pytest.mark.slow  # 400 frames through both back ends
@pytest.mark.parametrize("target, model", [("resection", "constant_velocity"), ("frame_landmarks", "wnoa")])
def test_fixed_lag_keeps_a_bounded_graph(target, model):
    # 400 frames at 30 fps with a loss every 100: the whole-sequence graph grows with every
    # frame, the fixed lag's holds the last 0.5 s (15 frames) and a few marginal priors.
    n, lag_s = 400, 0.5
    t, poses = wavy_trajectory(n)
    per_frame = {"resection": (2, 1), "frame_landmarks": (2 * BOARD.n + 1, BOARD.n + 2)}[target]
    full = SequenceGraph(K, BOARD, MotionPrior(model), target=target)
    lag = FixedLagGraph(K, BOARD, MotionPrior(model), target=target, lag_s=lag_s)
    sizes, full_sizes = [], []
    for k in range(n):
        if k % 100 == 0:
            full.break_segment()
            lag.break_segment()
        uv = project(K, poses[k], W)
        result = lag.add_frame(k, t[k], uv, ALL, poses[k], 0.1)
        np.testing.assert_allclose(result.T_WC, full.add_frame(k, t[k], uv, ALL, poses[k], 0.1).T_WC, atol=2e-6)
        sizes.append(lag.size())
        full_sizes.append(full.size())
    sizes, full_sizes = np.array(sizes), np.array(full_sizes)
    window = round(lag_s * 30) + 1
    bound = (window + 2) * np.array(per_frame)
    assert np.all(sizes <= bound), (sizes.max(axis=0), bound)
    assert np.all(sizes[100:].max(axis=0) == sizes[100:200].max(axis=0))  # flat once the lag is full
    assert np.all(full_sizes[-1] >= n * np.array(per_frame) - 2 * n)  # the whole graph does grow
    assert len(lag.measurements) == n  # kept for the batch smoothing, small


def test_fixed_lag_starts_a_segment_after_a_gap_longer_than_the_lag():
    # Frames 0-2 at 30 fps, then frame 3 five seconds later without a break: its
    # predecessors are marginalised, so no motion factor may reach them (GTSAM would not
    # find their keys).
    t, poses = wavy_trajectory(4)
    t = np.array([0.0, 1 / 30, 2 / 30, 5.0])
    graph = FixedLagGraph(K, BOARD, MotionPrior("random_walk", 1e-6, 1e-6), lag_s=1.0)
    for k in range(3):
        graph.add_frame(k, t[k], project(K, poses[0], W), ALL, poses[0], 0.1)
    result = graph.add_frame(3, t[3], project(K, poses[3], W), ALL, poses[3], 0.1)
    np.testing.assert_allclose(result.T_WC, poses[3], atol=1e-7)  # not dragged onto frame 2
    assert [m.new_segment for m in graph.measurements] == [True, False, False, True]
    np.testing.assert_allclose(graph.smooth()[3].T_WC, poses[3], atol=1e-7)


def test_fixed_lag_refuses_a_bad_lag_and_make_backend_picks_the_form():
    with pytest.raises(InputError, match="lag_s"):
        FixedLagGraph(K, BOARD, MotionPrior(), lag_s=0.0)
    assert isinstance(make_backend(K, BOARD, MotionPrior(), lag_s=None), SequenceGraph)
    graph = make_backend(K, BOARD, MotionPrior(), target="frame_landmarks", lag_s=1.5)
    assert isinstance(graph, FixedLagGraph) and graph.lag_s == 1.5 and graph.target == "frame_landmarks"
