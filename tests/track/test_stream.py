"""The tracker as a stream (graphpose.track_frames), its flat memory, and the calibration's
uncertainty in the tracked poses."""

import gc
import weakref

import numpy as np
import pytest

from graphpose import Board, InputError, track_frames, track_sequence
from graphpose.camera_models import PinholeCamera
from graphpose.pose.covariance import SIGMA_CALIBRATION, SIGMA_PIXEL, pose_cov_with_intrinsics
from graphpose.track.config import MotionPrior
from graphpose.track.fixed_lag import FixedLagGraph
from graphpose.track.results import LOST, FrameResult
from tests.conftest import PROJECT_K as K

BOARD = Board()

#: A calibration's covariance of (fx, fy, cx, cy): 0.5 px focal lengths (correlated), 0.4 px centre.
COV_K = np.diag([0.25, 0.25, 0.16, 0.16])
COV_K[0, 1] = COV_K[1, 0] = 0.9 * 0.25


@pytest.fixture(scope="module")
def clip():
    """12 rendered frames, no pan: every frame has a pose."""
    from graphpose.synth.sequence import render_sequence

    return render_sequence(K, 12, rng=2, excursions=0, supersample=1)


@pytest.fixture(scope="module")
def listed(clip):
    return track_sequence(clip.images, K, bounds=clip.bounds, timestamps=clip.timestamps, smooth=True)


def _same(a: FrameResult, b: FrameResult):
    """Every field equal but the wall times."""
    assert (a.index, a.status, a.junctions, a.message, a.sigma_kind) == (b.index, b.status, b.junctions, b.message,
                                                                       b.sigma_kind)
    assert a.timestamp == b.timestamp
    for name in ("T_WC", "cov", "cov_pixel", "single_T_WC", "points", "ids"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-15, err_msg=name)
    np.testing.assert_allclose(a.rms_px, b.rms_px, rtol=1e-12)


@pytest.mark.slow  # a rendered stream tracked twice
def test_the_stream_gives_the_lists_results(clip, listed):
    online = list(track_frames(clip.images, K, bounds=clip.bounds, timestamps=clip.timestamps))
    smoothed = list(track_frames(clip.images, K, bounds=clip.bounds, timestamps=clip.timestamps, smooth=True))
    assert [f.index for f in online] == [f.index for f in smoothed] == list(range(len(clip.images)))
    for a, b in zip(online, listed.frames):
        _same(a, b)
    for a, b in zip(smoothed, listed.smoothed):
        _same(a, b)
    assert all(f.status != LOST and f.sigma_kind == SIGMA_PIXEL and f.cov_pixel is f.cov for f in online)
    # Smoothing moved the poses: the two streams are not the same stream.
    assert max(np.abs(a.T_WC - b.T_WC).max() for a, b in zip(online, smoothed)) > 1e-9


@pytest.mark.slow  # a long rendered stream
def test_the_stream_keeps_no_result_it_gave(clip):
    # Memory flat however long the run: once the caller lets a result go, nothing holds it
    # but (until the next frame) the stream itself. Counted, never timed.
    given, alive = [], []
    for f in track_frames(clip.images, K, bounds=clip.bounds, timestamps=clip.timestamps):
        given.append(weakref.ref(f))
        del f
        gc.collect()
        alive.append([k for k, r in enumerate(given) if r() is not None])
    assert len(given) == len(clip.images)
    assert all(held in ([], [k]) for k, held in enumerate(alive)), alive
    gc.collect()
    assert all(r() is None for r in given)


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_fixed_lag_without_measurements_holds_only_the_indices(clip, listed):
    kept, bare = (FixedLagGraph(K, BOARD, MotionPrior(), keep_measurements=keep) for keep in (True, False))
    for f in listed.frames[:6]:
        for graph in (kept, bare):
            graph.add_frame(f.index, f.timestamp, f.points, f.ids, f.single_T_WC, 0.05)
    assert kept.frames == bare.frames == list(range(6))
    assert len(kept.measurements) == 6 and bare.measurements == ()
    assert sorted(bare.estimate()) == sorted(kept.estimate()) == list(range(6))
    with pytest.raises(InputError, match="kept no measurements"):
        bare.smooth()
    assert sorted(kept.smooth()) == list(range(6))


@pytest.mark.slow  # 1.0 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_calibrated_camera_widens_every_tracked_pose(clip, listed):
    plain = PinholeCamera(K)
    camera = plain.with_parameters(plain.parameters, COV_K)
    for smooth, reference in ((False, listed.frames), (True, listed.smoothed)):
        frames = list(track_frames(clip.images, camera, bounds=clip.bounds, timestamps=clip.timestamps,
                                   smooth=smooth))
        for f, g in zip(frames, reference):
            assert f.sigma_kind == SIGMA_CALIBRATION and g.sigma_kind == SIGMA_PIXEL
            # The poses and the pixel-only covariance are the plain camera's ...
            np.testing.assert_allclose(f.T_WC, g.T_WC, rtol=0, atol=1e-12)
            np.testing.assert_allclose(f.cov_pixel, g.cov, rtol=1e-9, atol=1e-20)
            # ... and the calibration adds D COV_K D^T: every sigma larger, the difference PSD.
            assert np.all(f.sigma > g.sigma)
            extra = f.cov - f.cov_pixel
            assert np.linalg.eigvalsh(extra).min() > -1e-9 * np.abs(extra).max()
            expected = pose_cov_with_intrinsics(camera, f.T_WC, BOARD.world_points()[:, f.ids], f.cov_pixel)
            np.testing.assert_allclose(f.cov, expected, rtol=1e-12, atol=0)
        # A 0.5 px focal length at about a metre: the depth sigma grows several-fold.
        z = np.median([f.sigma[2] / g.sigma[2] for f, g in zip(frames, reference)])
        assert z > 2.0, z


def test_the_stream_checks_its_inputs_when_called(clip):
    with pytest.raises(InputError, match="frames is empty"):
        track_frames([], K)
    with pytest.raises(InputError, match="config must be a TrackerConfig"):
        track_frames(clip.images, K, config="fast")
