"""Tracking a sequence: graphpose.track.tracker.track_sequence on rendered and real frames."""

import dataclasses

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

from graphpose import (
    Board,
    BoardNotFoundError,
    InputError,
    RadTanCamera,
    estimate_pose,
    track_sequence,
)
from graphpose.io.files import write_png
from graphpose.estimate import pose_difference
from graphpose.track import frontend
from graphpose.track.config import MotionPrior, TrackerConfig
from graphpose.track.frontend import board_symmetries
from graphpose.track.results import DETECTED, LOST, TRACKED
from tests.conftest import PROJECT_K as K


@pytest.fixture(scope="module")
def tracked(track_clip):
    return track_sequence(track_clip.images, K, bounds=track_clip.bounds, timestamps=track_clip.timestamps,
                          smooth=True)


@pytest.mark.slow  # renders and tracks a sequence that leaves the view
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


@pytest.mark.slow  # 1.2 s or so on two idle cores: a render, a calibration or a subprocess
def test_track_accuracy_against_truth(track_clip, tracked):
    # Regression guards from an earlier run of this test, with room for platform noise (measured RMSE about 0.12 mm online,
    # 0.11 mm smoothed); smoothing must not hurt. The frames of the whip pans themselves (the most smeared, the board
    # moving about a square during the exposure), which the front end follows by realigning since it keeps the board
    # through pans, are held apart: their junctions are biased by the smear (1-5 mm of pose error, fit RMS up to 0.21 px).
    found = tracked.found
    pan = track_clip.subframes == track_clip.subframes.max()
    rmse_mm = {}
    for which in ("online", "smoothed", "single"):
        P = tracked.poses(which)
        err = np.array([pose_difference(P[k], track_clip.T_WC[k])[0] for k in range(len(found))])
        rmse_mm[which] = 1000 * np.sqrt(np.mean(err[found & ~pan] ** 2))
        assert rmse_mm[which] < 0.3, which
        assert np.all(err[found & pan] < 0.01), which
    assert rmse_mm["smoothed"] <= rmse_mm["single"]
    for f in tracked.frames:
        if f.status != LOST:
            assert f.junctions >= TrackerConfig().min_junctions
            # regression guards (an earlier run): at most 0.016 px, 0.15 mm
            smeared = pan[f.index]
            assert f.rms_px < (0.3 if smeared else 0.1)
            assert np.all(f.sigma > 0) and np.all(f.sigma[:3] < (0.01 if smeared else 0.001))


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
    track = track_sequence(tmp_path, K, bounds=track_clip.bounds, timestamps=[10.0, 10.1, 10.2])
    assert list(track.status) == [DETECTED, TRACKED, TRACKED]
    np.testing.assert_allclose(track.timestamps, [10.0, 10.1, 10.2])


@pytest.mark.slow  # tracks a rendered folder
def test_an_unreadable_frame_file_is_lost_and_the_others_tracked(track_clip, tmp_path):
    # One corrupt file in the middle used to abort the whole run with an InputError.
    for k in range(6):
        write_png(tmp_path / f"f{k:02d}.png", track_clip.images[k])
    (tmp_path / "f03.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    track = track_sequence(tmp_path, K, bounds=track_clip.bounds, fps=track_clip.fps)
    assert list(track.status) == [DETECTED, TRACKED, TRACKED, LOST, DETECTED, TRACKED]
    message = track.frames[3].message
    assert "unreadable" in message and "f03.png" in message
    # A corrupt FIRST frame: the bounds belong to it, the next frames are searched without.
    (tmp_path / "f00.png").write_bytes(b"not an image")
    assert list(track_sequence(tmp_path, K, bounds=track_clip.bounds).status)[:3] == [LOST, DETECTED, TRACKED]


@pytest.mark.slow  # 0.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_every_frame_reports_the_time_of_its_parts(track_clip, tmp_path):
    for k in range(4):
        write_png(tmp_path / f"f{k:02d}.png", track_clip.images[k])
    (tmp_path / "f02.png").write_bytes(b"not an image")
    track = track_sequence(tmp_path, K, bounds=track_clip.bounds, fps=track_clip.fps)
    assert list(track.status) == [DETECTED, TRACKED, LOST, DETECTED]
    for f in track.frames:
        assert f.read_s > 0 and len(f.cpu_s) == 3 and min(f.cpu_s) >= 0
    for f in (track.frames[k] for k in (0, 1, 3)):
        assert f.frontend_s > 0 and f.update_s > 0
    # The unreadable frame reached neither the front end nor the back end.
    lost = track.frames[2]
    assert (lost.frontend_s, lost.update_s, lost.cpu_s[1:]) == (0.0, 0.0, (0.0, 0.0))


def test_a_missing_or_corrupt_frame_given_in_memory_is_an_input_error(track_clip):
    nan_frame = track_clip.images[1] / 255.0
    nan_frame[100, 100] = np.nan
    with pytest.raises(InputError, match="frame 1 .*NaN"):
        track_sequence([track_clip.images[0], nan_frame], K, bounds=track_clip.bounds)
    with pytest.raises(InputError, match="frame 1 must be"):
        track_sequence([track_clip.images[0], None], K, bounds=track_clip.bounds)


def test_counter_clockwise_bounds_are_the_same_input_error_as_in_estimate(track_clip):
    # The tracker used to take any finite 2 x 4 array and lose every frame on a reversed one.
    reverse = track_clip.bounds[:, ::-1]
    with pytest.raises(InputError) as single:
        estimate_pose(track_clip.images[0], K, bounds=reverse)
    with pytest.raises(InputError) as tracked:
        track_sequence(track_clip.images[:3], K, bounds=reverse)
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
    track = track_sequence(images, real_cases.K, bounds=real_images[0][0].bounds, polygons=polygons, smooth=True)
    assert len(track) == 6
    assert all(s in (TRACKED, DETECTED) for s in track.status)
    assert len(track.best_frames()) == 6
    for f in track.best_frames():
        assert f.rms_px < 1.0 and f.junctions >= 40


def test_track_input_errors(track_clip, tmp_path):
    images, bounds = track_clip.images[:2], track_clip.bounds
    with pytest.raises(InputError, match="empty"):
        track_sequence([], K, bounds=bounds)
    with pytest.raises(InputError, match="timestamps has"):
        track_sequence(images, K, bounds=bounds, timestamps=[0.0])
    with pytest.raises(InputError, match="increasing"):
        track_sequence(images, K, bounds=bounds, timestamps=[1.0, 1.0])
    with pytest.raises(InputError, match="fps"):
        track_sequence(images, K, bounds=bounds, fps=0.0)
    with pytest.raises(InputError, match="polygons has"):
        track_sequence(images, K, bounds=bounds, polygons=[None])
    with pytest.raises(InputError, match="polygons must be a sequence"):
        track_sequence(images, K, bounds=bounds, polygons=3)
    with pytest.raises(InputError, match=r"bounds must have shape \(2, 4\)"):
        track_sequence(images, K, bounds=np.zeros((2, 3)))
    with pytest.raises(InputError, match="motion model"):
        track_sequence(images, K, bounds=bounds, config=TrackerConfig(motion=MotionPrior("teleport")))
    with pytest.raises(InputError, match="config must be a TrackerConfig"):
        track_sequence(images, K, bounds=bounds, config={"min_junctions": 12})
    with pytest.raises(InputError, match="board must be a graphpose.Board"):
        track_sequence(images, K, bounds=bounds, board="8x6")
    with pytest.raises(InputError, match="K must have shape"):
        track_sequence(images, np.eye(2), bounds=bounds)
    with pytest.raises(InputError, match="frame 1"):
        track_sequence([images[0], np.zeros((2, 2, 2))], K, bounds=bounds)
    with pytest.raises(InputError, match="not found"):
        track_sequence(tmp_path / "nowhere", K, bounds=bounds)
    # A time-lapse (a frame every 2 s) under the 0.3 s default lag: the constant-velocity prior
    # would never reach its three poses, so every frame would start a segment of its own.
    with pytest.raises(InputError, match=r"lag_s = 0.3 s is shorter than the 3 frames \(4 s .* at least 8 s"):
        track_sequence(images, K, bounds=bounds, fps=0.5)
    track_sequence(images, K, bounds=bounds, fps=0.5, config=TrackerConfig(lag_s=8.0))
    track_sequence(images, K, bounds=bounds, fps=0.5, config=TrackerConfig(lag_s=None))


def test_float_and_colour_frames_track_as_8_bit_grey(track_clip):
    # Converted once per frame (graphpose.image.as_grey): the same junctions, the same poses.
    images = track_clip.images[:3]
    grey = track_sequence(images, K, bounds=track_clip.bounds)
    scaled = track_sequence([image / 255.0 for image in images], K, bounds=track_clip.bounds)
    colour = track_sequence([np.dstack([image] * 3) for image in images], K, bounds=track_clip.bounds)
    for other in (scaled, colour):
        assert list(other.status) == list(grey.status) == [DETECTED, TRACKED, TRACKED]
        np.testing.assert_allclose(other.poses("online"), grey.poses("online"), atol=1e-9)


# ------------------------------------------------------------------ raw frames, one camera


def distort_image(image, camera):
    """The raw frame a camera with ``camera``'s lens takes of the scene that the distortion-free
    camera with the same K saw as ``image``: each raw pixel's ray is found in the undistorted
    image (``camera.undistort_pixels``) and sampled there (cubic spline, the mean outside)."""
    h, w = image.shape
    v, u = np.mgrid[0:h, 0:w]
    ideal = camera.undistort_pixels(np.vstack([u.ravel(), v.ravel()]).astype(float))
    out = map_coordinates(image.astype(float), [ideal[1], ideal[0]], order=3, mode="constant", cval=np.nan)
    return np.clip(np.where(np.isnan(out), image.mean(), out), 0, 255).reshape(h, w).astype(np.uint8)


LENS = RadTanCamera(K, [-0.288, 0.097, 0.001, -0.0003, 0.0], size=(640, 480))


@pytest.fixture(scope="module")
def raw_clip(track_clip):
    """The clip's first 8 frames as a camera with a strong barrel lens (LENS) takes them."""
    return [distort_image(image, LENS) for image in track_clip.images[:8]]


@pytest.mark.slow  # renders and tracks raw frames through a lens
def test_raw_frames_track_through_the_camera_model(track_clip, raw_clip):
    track = track_sequence(raw_clip, LENS, timestamps=track_clip.timestamps[:8], smooth=True)
    assert list(track.status) == [DETECTED] + [TRACKED] * 7
    for which in ("online", "smoothed"):
        err = [pose_difference(T, track_clip.T_WC[k])[0] for k, T in enumerate(track.poses(which))]
        assert max(err) < 0.5e-3, (which, err)  # regression guard (an earlier run): 0.11 mm online, 0.08 mm smoothed
    assert max(f.rms_px for f in track.frames) < 0.1  # regression guard (an earlier run): 0.015 px at most
    # Tracked as if the frames were undistorted, the same frames fit much worse.
    pinhole = track_sequence(raw_clip[:3], K, timestamps=track_clip.timestamps[:3])
    found = [f for f in pinhole.frames if f.T_WC is not None]
    assert all(f.rms_px > 5 * max(g.rms_px for g in track.frames) for f in found)


@pytest.mark.slow  # 1.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_frame_of_another_size_than_the_calibration_is_refused(raw_clip):
    with pytest.raises(InputError, match=r"frame 1 is 320 x 240 pixels but the camera is calibrated for 640 x 480"):
        track_sequence([raw_clip[0], raw_clip[1][::2, ::2]], LENS)


# ------------------------------------------------------------------ detection without polygons


def _spy_extraction(monkeypatch, turn_after_first=False):
    """Record extract_junctions' (bounds, camera); with ``turn_after_first``, fail every later
    search inside a polygon and give a whole-image search the board's other labelling (its
    half turn, flagged ambiguous: what the upper-left rule gives a camera rolled past 90 deg)."""
    from graphpose.detect.junctions import extract_junctions

    calls = []

    def spy(image, bounds=None, board=None, *, camera=None, **kwargs):
        calls.append((None if bounds is None else np.asarray(bounds), camera))
        J = None
        if turn_after_first and len(calls) > 1:
            if bounds is not None:
                raise BoardNotFoundError("no board in this polygon (test)")
            J = extract_junctions(image, bounds=None, board=board, camera=camera)
            return dataclasses.replace(J, points=J.points[:, ::-1], trusted=J.trusted[::-1], seen=J.seen[::-1],
                                       orientation_ambiguous=True)
        return extract_junctions(image, board=board, bounds=bounds, camera=camera, **kwargs)

    monkeypatch.setattr(frontend, "extract_junctions", spy)
    return calls


def test_without_polygons_the_whole_image_is_searched_with_no_bounds(track_clip, monkeypatch):
    calls = _spy_extraction(monkeypatch)
    track = track_sequence(track_clip.images[:2], LENS.pinhole())
    assert list(track.status) == [DETECTED, TRACKED]
    assert len(calls) == 1 and calls[0][0] is None and calls[0][1] == LENS.pinhole()


def test_a_fresh_detection_of_a_symmetric_board_keeps_the_orientation(track_clip, monkeypatch):
    # Frame 2 is blank: frame 3 is found again by a whole-image search whose labels are the
    # board's half turn. The tracker takes the labelling nearest the last pose instead.
    frames = [track_clip.images[0], track_clip.images[1], np.full((480, 640), 128, np.uint8),
              track_clip.images[3], track_clip.images[4]]
    times = track_clip.timestamps[:5]
    calls = _spy_extraction(monkeypatch, turn_after_first=True)
    track = track_sequence(frames, K, bounds=track_clip.bounds, timestamps=times)
    assert list(track.status) == [DETECTED, TRACKED, LOST, DETECTED, TRACKED]
    assert any(bounds is None for bounds, _ in calls[1:])  # the whole-image search was reached
    for k in (0, 1, 3, 4):
        assert pose_difference(track.frames[k].T_WC, track_clip.T_WC[k])[0] < 1e-3, k
    # Without a pose to keep it continuous, the same search gives the turned board.
    first = track_sequence(frames[3:], K, timestamps=times[3:])
    assert pose_difference(first.frames[0].T_WC, track_clip.T_WC[3])[0] > 0.1


def test_board_symmetries_are_the_turns_of_the_grid():
    half, = board_symmetries(Board(8, 6))[1:]
    np.testing.assert_array_equal(half, np.arange(48)[::-1])
    square = Board(4, 4)
    perms = board_symmetries(square)
    assert len(perms) == 4
    c, r = square.grid_indices()
    for perm in perms:
        np.testing.assert_array_equal(np.sort(perm), np.arange(16))  # a relabelling
    # The first quarter turn takes junction (c, r) to (3 - r, c): corner 0 to corner 3.
    np.testing.assert_array_equal(perms[2], c * 4 + (3 - r))
    assert perms[2][0] == 3 and perms[3][0] == 12
    # Twice a quarter turn is the half turn.
    np.testing.assert_array_equal(perms[2][perms[2]], perms[1])


@pytest.mark.slow  # a rendered sequence tracked twice
def test_fixed_lag_tracker_matches_the_whole_sequence_graph_through_a_loss(track_clip, tracked):
    # The default back end is the fixed lag (0.3 s, on this 1.5 s clip: it marginalises most
    # frames), beside a 1 s lag and the whole-sequence graph. Same statuses (lost out of view, re-detected after), online
    # poses within the marginal priors' frozen linearisation (the bound of the back end's own
    # test, 2 um; measured identical to 1e-15 m here, as no marginalised pose needed
    # relinearising; the online error against the truth is about 0.1 mm), and the same
    # batch smoothing (measured 2e-12 m).
    assert tracked.config.lag_s == TrackerConfig().lag_s == 0.3
    runs = {lag: track_sequence(track_clip.images, K, bounds=track_clip.bounds, timestamps=track_clip.timestamps,
                                config=TrackerConfig(lag_s=lag), smooth=True) for lag in (1.0, None)}
    short, longer, whole = tracked, runs[1.0], runs[None]
    assert list(short.status) == list(whole.status) == list(longer.status)
    assert LOST in short.status and DETECTED in short.status[1:]  # a loss and a re-detection
    found = short.found
    for run in (short, longer):
        np.testing.assert_allclose(run.poses("online")[found], whole.poses("online")[found], atol=2e-6)
        np.testing.assert_allclose(run.poses("smoothed")[found], whole.poses("smoothed")[found], atol=1e-7)
    for a, b in zip(short.smoothed, whole.smoothed):
        if a.cov is not None:
            np.testing.assert_allclose(a.cov, b.cov, rtol=1e-4)
