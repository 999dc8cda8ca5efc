"""The back ends' interface, graphpose.track.backend (Backend, make_backend); the whole-sequence
graph, the fixed lag and the factor model have their own files."""

import gtsam
import numpy as np
import pytest

from graphpose import Board, project
from graphpose.track.backend import Backend, make_backend
from graphpose.track.config import MotionPrior
from graphpose.track.model import FrameMeasurement
from graphpose.track.smoothing import smooth_frames
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K
from tests.helpers import wavy_trajectory

BOARD = Board()
ALL = np.arange(BOARD.n)


@pytest.mark.parametrize("lag_s", [1.0, None])
def test_both_back_ends_offer_the_whole_interface(lag_s):
    t, poses = wavy_trajectory(4)
    graph = make_backend(K, BOARD, MotionPrior(), target="frame_landmarks", lag_s=lag_s)
    assert isinstance(graph, Backend) and graph.lag_s == lag_s
    assert gtsam.Symbol(graph.landmark_key(300, 3)).string() == "l30003"
    seen = [ALL, ALL, ALL[5:], ALL]
    for k in range(4):
        if k == 2:
            graph.break_segment()
        graph.add_frame(k, t[k], project(K, poses[k], W[:, seen[k]]), seen[k], poses[k], 0.1 + k)
    assert graph.frames == [0, 1, 2, 3]
    assert all(isinstance(m, FrameMeasurement) for m in graph.measurements)
    assert [m.new_segment for m in graph.measurements] == [True, False, True, False]
    assert [m.timestamp for m in graph.measurements] == list(t)
    assert [m.pixel_sigma for m in graph.measurements] == [0.1, 1.1, 2.1, 3.1]
    np.testing.assert_array_equal(graph.measurements[2].ids, ALL[5:])
    np.testing.assert_array_equal(graph.measurements[2].points, project(K, poses[2], W[:, 5:]))
    # The measurements are all it takes to rebuild the sequence's graph: the same smoothing.
    rebuilt = smooth_frames(K, BOARD, MotionPrior(), "frame_landmarks", graph.measurements, graph.estimate())
    for k, result in graph.smooth().items():
        np.testing.assert_allclose(rebuilt[k].T_WC, result.T_WC, atol=1e-9)
        np.testing.assert_allclose(rebuilt[k].cov, result.cov, rtol=1e-6, atol=1e-14)
