"""graphpose.synth.clip: a calibration clip's truth and its frames."""

import pytest
import numpy as np

from graphpose import Board
from graphpose.camera_models import PinholeCamera
from graphpose.geometry import to_camera
from graphpose.synth.clip import CalibrationClip, calibration_clip
from graphpose.synth.render import render_ideal

BOARD = Board(5, 4, 0.05)  # a small board: a quick render


def pinhole_camera():
    """The clip draws for any camera model: a pinhole one (of synth.calibration's radtan camera's
    K and size) draws its key poses ten times faster than a lens, which must be unprojected."""
    return PinholeCamera([[530.0, 0.0, 322.5], [0.0, 528.0, 241.0], [0.0, 0.0, 1.0]], size=(640, 480))


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_clip_is_its_poses_truth():
    camera = pinhole_camera()
    clip = calibration_clip(camera, seconds=3.0, fps=10.0, rng=1, board=BOARD)
    assert isinstance(clip, CalibrationClip) and len(clip) == 30 and clip.T_WC.shape == (30, 4, 4)
    np.testing.assert_allclose(clip.timestamps, np.arange(30) / 10.0, atol=1e-12)
    # visible: the share of junctions inside the image, counted here independently.
    width, height = camera.size
    for k in range(len(clip)):
        uv = camera.project(to_camera(clip.T_WC[k], BOARD.world_points()))
        inside = (uv[0] >= 0) & (uv[0] <= width - 1) & (uv[1] >= 0) & (uv[1] <= height - 1)
        assert clip.visible[k] == inside.mean()
        R = clip.T_WC[k, :3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)  # interpolated poses stay rotations
    assert clip.visible.max() == 1.0
    pushed = calibration_clip(camera, seconds=3.0, fps=10.0, rng=1, board=BOARD, partial_share=1.0)
    assert pushed.visible.min() < 1.0  # keys pushed partly out of the image
    # A smooth path: frame-to-frame steps are a small part of the whole way travelled.
    steps = np.linalg.norm(np.diff(clip.T_WC[:, :3, 3], axis=0), axis=1)
    assert steps.max() < 0.2 * steps.sum()


def test_frames_blur_only_where_the_junctions_move_fast():
    camera = pinhole_camera()
    sharp = calibration_clip(camera, seconds=3.0, fps=10.0, rng=1, board=BOARD, blur_threshold_px=1e6)
    assert np.all(sharp.subframes == 1)
    blurred = calibration_clip(camera, seconds=3.0, fps=10.0, rng=1, board=BOARD, max_subframes=5)
    np.testing.assert_array_equal(blurred.T_WC, sharp.T_WC)  # the threshold changes the exposure only
    assert blurred.subframes.max() == 5 and blurred.subframes.min() == 1
    # Junction motion over half a frame, against the threshold of 1.5 px.
    uv = np.stack([camera.project(to_camera(T, BOARD.world_points())) for T in sharp.T_WC])
    half = 0.5 * np.linalg.norm(np.diff(uv, axis=0), axis=1).max(axis=1)
    fast = np.flatnonzero(sharp.visible[1:] == 1.0) + 1  # frames whose junctions are all in view
    np.testing.assert_array_equal(blurred.subframes[fast] > 1, half[fast - 1] > 1.5)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_sharp_noise_free_frame_is_the_render_at_its_pose():
    clip = calibration_clip(pinhole_camera(), seconds=1.0, fps=4.0, rng=3, board=BOARD, blur_threshold_px=1e6,
                            noise_sigma=0.0)
    frames = list(clip.frames())
    assert len(frames) == 4
    for k, frame in enumerate(frames):
        ideal = render_ideal(clip.camera, clip.T_WC[k], BOARD, supersample=1)
        assert frame.dtype == np.uint8
        assert np.abs(frame.astype(float) - ideal).max() <= 0.5 + 1e-9  # rounded to grey levels
    # The noise is seeded per clip: the frames repeat.
    noisy = calibration_clip(pinhole_camera(), seconds=1.0, fps=4.0, rng=3, board=BOARD)
    for a, b in zip(noisy.frames(), noisy.frames()):
        np.testing.assert_array_equal(a, b)
