"""Tracking a sequence: graphpose.track.tracker.track_sequence on rendered and real frames."""

import numpy as np
import pytest

from graphpose import InputError, estimate_pose, track_sequence
from graphpose.io.files import write_png
from graphpose.pose.estimate import pose_difference
from graphpose.track.config import MotionPrior, TrackerConfig
from graphpose.track.results import DETECTED, LOST, TRACKED
from tests.conftest import PROJECT_K as K


@pytest.fixture(scope="module")
def tracked(track_clip):
    return track_sequence(track_clip.images, K, track_clip.bounds, timestamps=track_clip.timestamps, smooth=True)


def test_track_reports_out_of_view_frames_lost_and_recovers(track_clip, tracked):
    clip, status = track_clip, tracked.status
    assert status[0] == DETECTED
    assert clip.out_of_view.any()
    assert np.all(status[clip.out_of_view] == LOST)
    last_out = np.flatnonzero(clip.out_of_view)[-1]
    after = np.flatnonzero(clip.in_view & (np.arange(len(clip)) > last_out))
    # Back on the board within a few frames of its full return, then tracked to the end.
    assert np.all(status[after[4:]] != LOST)
    assert TRACKED in status[after]
    for f in tracked.frames:
        assert (f.T_WC is None) == (f.status == LOST)
        assert (f.cov is None) == (f.status == LOST)


def test_track_accuracy_against_truth(track_clip, tracked):
    # Regression guards with room for platform noise (measured RMSE about 0.12 mm online,
    # 0.11 mm smoothed); smoothing must not hurt.
    found = tracked.found
    rmse_mm = {}
    for which in ("online", "smoothed", "single"):
        P = tracked.poses(which)
        err = [pose_difference(P[k], track_clip.T_WC[k]) for k in np.flatnonzero(found)]
        rmse_mm[which] = 1000 * np.sqrt(np.mean(np.array(err)[:, 0] ** 2))
        assert rmse_mm[which] < 0.3, which
    assert rmse_mm["smoothed"] <= rmse_mm["single"]
    for f in tracked.frames:
        if f.status != LOST:
            assert f.junctions >= TrackerConfig().min_junctions
            assert f.reprojection_rms_px < 0.1  # measured at most 0.016 px
            assert np.all(f.sigma > 0) and np.all(f.sigma[:3] < 0.001)  # measured at most 0.15 mm


def test_track_without_any_polygon_searches_the_whole_image(track_clip):
    seen = []
    track = track_sequence(track_clip.images[:4], K, progress=lambda k, n: seen.append((k, n)))
    assert list(track.status) == [DETECTED, TRACKED, TRACKED, TRACKED]
    assert seen == [(0, 4), (1, 4), (2, 4), (3, 4)]
    np.testing.assert_allclose(track.poses("online")[:, :3, 3], track_clip.T_WC[:4, :3, 3], atol=1e-3)


def test_track_reads_a_folder(track_clip, tmp_path):
    for k in range(3):
        write_png(tmp_path / f"f{k:02d}.png", track_clip.images[k])
    (tmp_path / "notes.txt").write_text("not a frame")
    track = track_sequence(tmp_path, K, track_clip.bounds, timestamps=[10.0, 10.1, 10.2])
    assert list(track.status) == [DETECTED, TRACKED, TRACKED]
    np.testing.assert_allclose(track.timestamps, [10.0, 10.1, 10.2])


def test_an_unreadable_frame_file_is_lost_and_the_others_tracked(track_clip, tmp_path):
    # One corrupt file in the middle used to abort the whole run with an InputError.
    for k in range(6):
        write_png(tmp_path / f"f{k:02d}.png", track_clip.images[k])
    (tmp_path / "f03.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    track = track_sequence(tmp_path, K, track_clip.bounds, fps=track_clip.fps)
    assert list(track.status) == [DETECTED, TRACKED, TRACKED, LOST, DETECTED, TRACKED]
    message = track.frames[3].message
    assert "unreadable" in message and "f03.png" in message
    # A corrupt FIRST frame: the bounds belong to it, the next frames are searched without.
    (tmp_path / "f00.png").write_bytes(b"not an image")
    assert list(track_sequence(tmp_path, K, track_clip.bounds).status)[:3] == [LOST, DETECTED, TRACKED]


def test_a_missing_or_corrupt_frame_given_in_memory_is_an_input_error(track_clip):
    nan_frame = track_clip.images[1] / 255.0
    nan_frame[100, 100] = np.nan
    with pytest.raises(InputError, match="frame 1 .*NaN"):
        track_sequence([track_clip.images[0], nan_frame], K, track_clip.bounds)
    with pytest.raises(InputError, match="frame 1 must be"):
        track_sequence([track_clip.images[0], None], K, track_clip.bounds)


def test_counter_clockwise_bounds_are_the_same_input_error_as_in_estimate(track_clip):
    # The tracker used to take any finite 2 x 4 array and lose every frame on a reversed one.
    reverse = track_clip.bounds[:, ::-1]
    with pytest.raises(InputError) as single:
        estimate_pose(track_clip.images[0], reverse, K)
    with pytest.raises(InputError) as tracked:
        track_sequence(track_clip.images[:3], K, reverse)
    assert "clockwise" in str(single.value)
    assert str(tracked.value) == str(single.value)


def test_per_frame_polygons_are_checked_like_bounds(track_clip):
    images = track_clip.images[:3]
    bad = [None, None, track_clip.bounds[:, ::-1]]
    with pytest.raises(InputError, match=r"polygons\[2\] must run clockwise"):
        track_sequence(images, K, polygons=bad)
    with pytest.raises(InputError, match=r"polygons\[1\] vertices \[.*\] lie off the 640 x 480 image"):
        track_sequence(images, K, polygons=[None, track_clip.bounds + 2000.0, None])
    with pytest.raises(InputError, match=r"polygons\[0\] must have shape \(2, 4\)"):
        track_sequence(images, K, polygons=[np.zeros((2, 3)), None, None])
    track = track_sequence(images, K, polygons=[track_clip.bounds, None, None])
    assert list(track.status) == [DETECTED, TRACKED, TRACKED]


def test_real_images_as_a_jumpy_sequence(real_cases, real_images):
    images = [image for _, image in real_images]
    polygons = [case.bounds for case, _ in real_images]
    track = track_sequence(images, real_cases.K, real_images[0][0].bounds, polygons=polygons, smooth=True)
    assert len(track) == 6
    assert all(s in (TRACKED, DETECTED) for s in track.status)
    assert len(track.best_frames()) == 6
    for f in track.best_frames():
        assert f.reprojection_rms_px < 1.0 and f.junctions >= 40


def test_track_input_errors(track_clip, tmp_path):
    images, bounds = track_clip.images[:2], track_clip.bounds
    with pytest.raises(InputError, match="empty"):
        track_sequence([], K, bounds)
    with pytest.raises(InputError, match="timestamps has"):
        track_sequence(images, K, bounds, timestamps=[0.0])
    with pytest.raises(InputError, match="increasing"):
        track_sequence(images, K, bounds, timestamps=[1.0, 1.0])
    with pytest.raises(InputError, match="fps"):
        track_sequence(images, K, bounds, fps=0.0)
    with pytest.raises(InputError, match="polygons has"):
        track_sequence(images, K, bounds, polygons=[None])
    with pytest.raises(InputError, match="polygons must be a sequence"):
        track_sequence(images, K, bounds, polygons=3)
    with pytest.raises(InputError, match=r"bounds must have shape \(2, 4\)"):
        track_sequence(images, K, np.zeros((2, 3)))
    with pytest.raises(InputError, match="motion model"):
        track_sequence(images, K, bounds, config=TrackerConfig(motion=MotionPrior("teleport")))
    with pytest.raises(InputError, match="config must be a TrackerConfig"):
        track_sequence(images, K, bounds, config={"min_junctions": 12})
    with pytest.raises(InputError, match="board must be a graphpose.Board"):
        track_sequence(images, K, bounds, board="8x6")
    with pytest.raises(InputError, match="K must have shape"):
        track_sequence(images, np.eye(2), bounds)
    with pytest.raises(InputError, match="frame 1"):
        track_sequence([images[0], np.zeros((2, 2, 2))], K, bounds)
    with pytest.raises(InputError, match="not found"):
        track_sequence(tmp_path / "nowhere", K, bounds)


def test_float_and_colour_frames_track_as_8_bit_grey(track_clip):
    # Converted once per frame (graphpose.image.as_grey): the same junctions, the same poses.
    images = track_clip.images[:3]
    grey = track_sequence(images, K, track_clip.bounds)
    scaled = track_sequence([image / 255.0 for image in images], K, track_clip.bounds)
    colour = track_sequence([np.dstack([image] * 3) for image in images], K, track_clip.bounds)
    for other in (scaled, colour):
        assert list(other.status) == list(grey.status) == [DETECTED, TRACKED, TRACKED]
        np.testing.assert_allclose(other.poses("online"), grey.poses("online"), atol=1e-9)
