"""Tracker results: graphpose.track.results."""

import numpy as np
import pytest

from graphpose import InputError, T_from_params
from graphpose.track.config import TrackerConfig
from graphpose.track.results import DETECTED, LOST, TRACKED, FrameResult, Track


def _frames(n=6, lost=(2, 3)):
    out = []
    for k in range(n):
        if k in lost:
            out.append(FrameResult(k, k / 30.0, LOST, message="out of view"))
            continue
        T = T_from_params([0.1 + 0.01 * k, 0.1, -1.0, 0.0, 0.0, 0.01 * k])
        single = T_from_params([0.1 + 0.01 * k, 0.1, -1.001, 0.0, 0.0, 0.01 * k])
        cov = np.diag([1e-8, 4e-8, 9e-8, 1e-6, 4e-6, 9e-6])
        out.append(FrameResult(k, k / 30.0, DETECTED if k in (0, 4) else TRACKED, T, cov, 48, 0.01, single))
    return tuple(out)


def test_track_accessors():
    frames = _frames()
    track = Track(frames, None, TrackerConfig())
    assert len(track) == 6
    np.testing.assert_allclose(track.timestamps, np.arange(6) / 30.0)
    assert list(track.status) == [DETECTED, TRACKED, LOST, LOST, DETECTED, TRACKED]
    np.testing.assert_array_equal(track.found, [True, True, False, False, True, True])
    online, single = track.poses("online"), track.poses("single")
    assert np.all(np.isnan(online[2:4])) and np.all(np.isnan(single[2:4]))
    np.testing.assert_array_equal(online[0], frames[0].T_WC)
    np.testing.assert_array_equal(single[5], frames[5].single_T_WC)
    np.testing.assert_array_equal(track.poses("best"), online)
    assert track.best_frames() is frames
    np.testing.assert_allclose(frames[0].sigma, [1e-4, 2e-4, 3e-4, 1e-3, 2e-3, 3e-3])
    assert frames[2].sigma is None


def test_smoothed_track_prefers_its_smoothed_frames():
    frames = _frames()
    moved = tuple(FrameResult(f.index, f.timestamp, f.status, None if f.T_WC is None else f.T_WC + 0.0,
                              f.cov, f.junctions, f.rms_px, f.single_T_WC) for f in frames)
    track = Track(frames, moved, TrackerConfig())
    assert track.best_frames() is moved
    np.testing.assert_array_equal(track.poses("best"), track.poses("smoothed"))


def test_poses_refuses():
    track = Track(_frames(), None, TrackerConfig())
    with pytest.raises(InputError, match="which"):
        track.poses("median")
    with pytest.raises(InputError, match="not smoothed"):
        track.poses("smoothed")
