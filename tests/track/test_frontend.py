"""The tracker's front end: graphpose.track.frontend."""

import gtsam
import numpy as np
import pytest

from graphpose import Board, InputError, T_from_params, track_sequence
from graphpose.estimate import fit_pose
from graphpose.synth.sequence import render_sequence
from graphpose.track import frontend
from graphpose.track.config import TrackerConfig
from graphpose.track.frontend import FrontEnd, constant_velocity_prediction
from graphpose.track.results import DETECTED, LOST, TRACKED
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-5, 1e-3, 0.05, 1.0, 3.0, np.pi - 1e-6])
def test_constant_velocity_prediction_is_gtsams_exp_and_log(angle):
    # T1 Exp(r Log(T0^-1 T1)) with GTSAM's Pose3 maps, for relative rotations from none to
    # almost half a turn (the closed forms switch to series near 0 and to the symmetric part
    # near pi).
    rng = np.random.default_rng(int(angle * 1e3) + 1)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    T0 = T_from_params([0.2, 0.1, -0.9, 0.3, -0.2, 0.1])
    T1 = T0 @ gtsam.Pose3.Expmap(np.r_[angle * axis, rng.normal(0, 0.02, 3)]).matrix()
    for ratio in (1.0, 0.5, 2.5):
        twist = gtsam.Pose3.Logmap(gtsam.Pose3(np.linalg.inv(T0) @ T1))
        expected = T1 @ gtsam.Pose3.Expmap(ratio * twist).matrix()
        np.testing.assert_allclose(constant_velocity_prediction(T0, T1, ratio), expected, atol=1e-9)


def _first_two(clip, config=None):
    front = FrontEnd(K, Board(), config or TrackerConfig())
    first = front.measure(0, clip.timestamps[0], clip.images[0], clip.bounds)
    front.accept(0, clip.timestamps[0], first.fit.T_WC, clip.images[0].shape)
    second = front.measure(1, clip.timestamps[1], clip.images[1])
    return first, second


def test_detects_then_tracks_with_the_single_image_fit(track_clip):
    first, second = _first_two(track_clip)
    assert (first.status, second.status) == (DETECTED, TRACKED)
    assert first.points.shape == (2, first.ids.size) and first.ids.size >= 44
    # The single-image pipeline's fit, from the homography for a detection.
    fit, _ = fit_pose(first.points, W[:, first.ids], K)
    np.testing.assert_allclose(first.fit.T_WC, fit.T_WC, atol=1e-12)
    assert first.fit.sigma_px == fit.sigma_px
    for found, k in ((first, 0), (second, 1)):
        assert np.linalg.norm(found.fit.T_WC[:3, 3] - track_clip.T_WC[k][:3, 3]) < 5e-4


def test_robust_setting_is_the_pipelines_robust_fit(track_clip):
    first, _ = _first_two(track_clip, TrackerConfig(robust=True))
    fit, _ = fit_pose(first.points, W[:, first.ids], K, robust=True)
    np.testing.assert_allclose(first.fit.T_WC, fit.T_WC, atol=1e-12)
    assert first.fit.sigma_px == fit.sigma_px  # the robust sigma (1.4826 x median |residual|)
    plain, _ = fit_pose(first.points, W[:, first.ids], K)
    assert first.fit.sigma_px != plain.sigma_px


def test_a_detection_whose_squares_show_the_other_colours_is_refused(track_clip):
    # The board's light-minus-dark sense is measured at each detection and the colour check of
    # the frames tracked after it reads it: a re-detection one square off shows the squares the
    # other way round, and is refused rather than taken as the sequence's new sense.
    front = FrontEnd(K, Board(), TrackerConfig())
    first = front.measure(0, track_clip.timestamps[0], track_clip.images[0], track_clip.bounds)
    assert first.status == DETECTED and front._contrast != 0.0
    front._contrast = -front._contrast  # as if the sequence's board had shown the other colours
    again = front.measure(1, track_clip.timestamps[1], track_clip.images[1], track_clip.bounds)
    assert again.status == LOST and "other colours" in again.message


def test_no_board_is_lost_with_the_reasons():
    front = FrontEnd(K, Board(), TrackerConfig())
    found = front.measure(0, 0.0, np.full((480, 640), 128, np.uint8))
    assert found.status == LOST and found.points is None and found.fit is None
    assert "extraction failed" in found.message


def test_input_errors_of_the_junction_and_pose_code_fail_the_attempt_not_the_sequence(track_clip, monkeypatch):
    def refuse(*args, **kwargs):
        raise InputError("degenerate")

    # A refinement that fails once tracking started: each frame falls back to full extraction.
    monkeypatch.setattr(frontend, "refine_junctions", refuse)
    track = track_sequence(track_clip.images[:3], K, bounds=track_clip.bounds)
    assert list(track.status) == [DETECTED, DETECTED, DETECTED]
    assert all("track failed: degenerate" in f.message for f in track.frames[1:])
    # The single-image fit failing from the homography start: every attempt fails, every
    # frame is lost, and says why.
    monkeypatch.setattr("graphpose.estimate.pose_from_homography", refuse)
    track = track_sequence(track_clip.images[:2], K, bounds=track_clip.bounds)
    assert list(track.status) == [LOST, LOST]
    assert all("pose fit failed: degenerate" in f.message for f in track.frames)


@pytest.fixture(scope="module")
def help_example():
    """The sequence of 'graphpose render-sequence --frames 60 --seed 3 --excursions 1' (cheap
    rendering): the board leaves the view in a whip pan and comes back large, near the image
    border, the sheet's white margin cut by it."""
    return render_sequence(K, 60, rng=3, excursions=1, supersample=1)


@pytest.mark.slow  # renders and tracks a panning sequence
def test_the_board_is_found_again_after_a_pan_when_the_sheet_was_cut_by_the_border(help_example):
    # Re-detection after a loss searches around the last frame whose junctions were all in
    # the image. It used to take only frames whose whole SHEET (margin included) was in the
    # image: here that was frame 11, the board has moved far since, and the whole-image
    # search cannot find a board this large in this perspective, so every frame after the
    # pan was lost although the board was in view and sharp.
    seq = help_example
    track = track_sequence(seq.images, K, timestamps=seq.timestamps)
    status = track.status
    last_out = np.flatnonzero(seq.out_of_view)[-1]
    back = np.flatnonzero((np.arange(len(seq)) > last_out) & seq.in_view & (seq.subframes == 1))
    assert back.size >= 10
    assert not np.any(status[back] == LOST), dict(zip(back.tolist(), status[back]))
    found = track.found
    err = np.linalg.norm(track.poses("online")[found, :3, 3] - seq.T_WC[found, :3, 3], axis=1)
    # The sharp frames to a millimetre; the frames of the pan itself (16 renders averaged, the
    # board smeared over a square), realigned since the front end follows them, to a few.
    sharp = seq.subframes[found] == 1
    assert np.max(err[sharp]) < 1e-3
    assert np.max(err[~sharp]) < 5e-3


def test_a_noisy_board_is_redetected_after_a_loss_and_tracked_with_more_smoothing():
    # Noise 16, blur 2: a frame the fast search alone refused. After a loss the front end
    # detects it with the noise-aware search, then tracks the next frame (the same pose)
    # with the smoothing the noise asks for.
    from graphpose.detect.refine import SMOOTH_SIGMA
    from graphpose.synth.poses import random_pose
    from graphpose.synth.render import render

    rng = np.random.default_rng(0)
    T = random_pose(K, Board(), (640, 480), distance=(0.6, 0.9), rng=rng)
    frames = [render(K, T, Board(), (640, 480), noise_sigma=16.0, blur_sigma=2.0, rng=seed).image for seed in (1, 2)]
    front = FrontEnd(K, Board(), TrackerConfig())
    front.lose()
    first = front.measure(0, 0.0, frames[0])
    assert first.status == DETECTED and first.ids.size >= 44
    np.testing.assert_allclose(first.fit.T_WC[:3, 3], T[:3, 3], atol=5e-3)
    assert front._smooth > SMOOTH_SIGMA
    front.accept(0, 0.0, first.fit.T_WC, frames[0].shape)
    second = front.measure(1, 1 / 30, frames[1])
    assert second.status == TRACKED and second.ids.size >= 44
    np.testing.assert_allclose(second.fit.T_WC[:3, 3], T[:3, 3], atol=5e-3)


def test_the_running_median_of_the_fit_rms_is_numpys_to_the_bit():
    # The frame-RMS check's median of every frame so far, kept in two heaps instead of
    # np.median over the growing list (O(n) a frame); ties and both parities.
    rng = np.random.default_rng(5)
    values = np.r_[rng.gamma(2.0, 0.01, 300), np.round(rng.normal(0.05, 0.01, 300), 3), [0.0] * 5]
    rng.shuffle(values)
    running = frontend.RunningMedian()
    assert np.isnan(running.median()) and len(running) == 0
    for k, v in enumerate(values, start=1):
        running.add(v)
        assert len(running) == k
        assert running.median() == np.median(values[:k]), k


def _whip(x, seed):
    """A view of the board from camera position x (metres, the rest fixed) and its image."""
    from graphpose.synth.render import render

    T = T_from_params([x, 0.17, -0.75, 0.08, -0.1, 0.05])
    return T, render(K, T, Board(), noise_sigma=4.0, rng=seed, blur_sigma=1.5).image


def _labels_right(m, T):
    from graphpose.geometry import to_camera

    truth = (K @ to_camera(T, W))
    truth = truth[:2] / truth[2]
    return bool(np.all(np.hypot(*(m.points - truth[:, m.ids])) < 1.0))


def test_a_prediction_half_a_square_off_is_realigned_by_the_boards_edges():
    # Two still frames, then the camera jumps 40 mm (0.63 squares, 30 px) sideways with the
    # board's left columns out of view: the constant-velocity prediction (no motion) is beyond
    # the refinement's reach; realigned onto the squares, the frame is tracked, every junction
    # labelled as the truth.
    front = FrontEnd(K, Board(), TrackerConfig())
    T0, image0 = _whip(0.46, 1)
    first = front.measure(0, 0.0, image0, _outline(T0))
    assert first.status == DETECTED
    for k in (0, 1):
        front.accept(k, k / 30, first.fit.T_WC, image0.shape)
    T2, image2 = _whip(0.50, 2)
    m = front.measure(2, 2 / 30, image2)
    assert m.status == TRACKED and m.ids.size >= 30 and _labels_right(m, T2)
    assert front._track(image2, front._predict(2, 2 / 30))[0] is None  # the plain refinement could not


def test_after_a_loss_the_board_is_reacquired_from_a_recent_view():
    front = FrontEnd(K, Board(), TrackerConfig())
    T0, image0 = _whip(0.46, 1)
    first = front.measure(0, 0.0, image0, _outline(T0))
    front.accept(0, 0.0, first.fit.T_WC, image0.shape)
    assert front.measure(1, 1 / 30, np.full_like(image0, 60)).status == LOST
    front.lose()
    T2, image2 = _whip(0.50, 2)
    found = front._reacquire(image2, None)
    assert found is not None
    m = frontend.Measurement(DETECTED, *found)
    assert _labels_right(m, T2)


def test_a_realigned_labelling_that_no_edge_fixes_is_refused():
    # Close up at the board's middle, no edge in view: however well the squares line up, every
    # placement of the board fits them as well, and the frame is not realigned.
    from graphpose.synth.render import render

    front = FrontEnd(K, Board(), TrackerConfig())
    T0, image0 = _whip(0.46, 1)
    first = front.measure(0, 0.0, image0, _outline(T0))
    front.accept(0, 0.0, first.fit.T_WC, image0.shape)
    T = T_from_params([0.25, 0.19, -0.38, 0.08, -0.1, 0.05])
    image = render(K, T, Board(), noise_sigma=4.0, rng=3, blur_sigma=1.5).image
    found, why = front._realign(image, T_from_params([0.272, 0.19, -0.38, 0.08, -0.1, 0.05]))
    assert found is None and "do not fix its labels" in why


def _outline(T):
    from graphpose.geometry import to_camera

    P = K @ to_camera(T, Board().sheet_corners())
    return P[:2] / P[2]
