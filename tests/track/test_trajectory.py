import numpy as np

from graphpose.geometry import T_from_params
from graphpose.track.trajectory import MAX_TIME_DIFFERENCE_S, associate, trajectory_errors


def _poses(n):
    return np.stack([T_from_params([0.01 * k, 0.0, -1.0, 0.0, 0.0, 0.001 * k]) for k in range(n)])


def test_associate_takes_the_nearest_pose_within_the_tolerance_and_nan_otherwise():
    poses = _poses(4)
    times = np.array([0.0, 0.1, 0.2, 0.3])
    # Given out of order; frames at 0.004 (near 0.0), 0.2 (exact), 0.25 (no pose within 10 ms).
    shuffled = [2, 0, 3, 1]
    out = associate(times[shuffled], poses[shuffled], np.array([0.004, 0.2, 0.25]))
    np.testing.assert_array_equal(out[0], poses[0])
    np.testing.assert_array_equal(out[1], poses[2])
    assert np.all(np.isnan(out[2]))
    assert MAX_TIME_DIFFERENCE_S == 0.01


def test_associate_tolerance_is_at_most_half_the_shortest_frame_interval():
    poses = _poses(2)
    # Frames 8 ms apart: a pose 5 ms from a frame is more than half an interval off.
    out = associate([0.0, 0.105], poses, np.array([0.1, 0.108]))
    assert np.all(np.isnan(out[0]))
    np.testing.assert_array_equal(out[1], poses[1])
    assert np.all(np.isnan(associate([], np.empty((0, 4, 4)), np.array([0.0, 1.0]))))


def test_trajectory_errors_per_frame_and_nan_where_a_pose_is_missing():
    truth = _poses(3)
    est = truth.copy()
    est[0, :3, 3] += [0.003, 0.004, 0.0]  # 5 mm off
    est[1] = T_from_params([0.01, 0.0, -1.0, 0.0, 0.0, 0.001 + np.radians(0.5)])  # 0.5 degree off in yaw
    est[2] = np.nan
    e = trajectory_errors(est, truth)
    np.testing.assert_allclose(e[0], [0.005, 0.0], atol=1e-12)
    np.testing.assert_allclose(e[1], [0.0, 0.5], atol=1e-9)
    assert np.all(np.isnan(e[2]))
