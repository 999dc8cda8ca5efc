"""A wrong board spec gives a refusal that names the board seen, never another board's junctions.

On OpenCV's samples (a 9 x 6 board; in three of the left images a small picture of the same
board on a monitor in the background) an 8 x 6 spec is refused on every image, naming the
9 x 6 board. Rendered: a 9 x 6 board under an 8 x 6 spec, and a large board beside a small
picture of a board, which the 8 x 6 spec would otherwise label (as it did on the real images).
"""

import subprocess
import sys

import numpy as np
import pytest

from graphpose import Board, BoardMismatchError, BoardNotFoundError, extract_junctions, read_image
from graphpose.io.cameras import read_camera
from graphpose.synth.degrade import jpeg_roundtrip
from graphpose.synth.render import render
from tests.conftest import OPENCV_DIR, opencv_file

LEFT = [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14]
K = np.array([[565.0, 0.0, 320.0], [0.0, 565.0, 240.0], [0.0, 0.0, 1.0]])
NINE_BY_SIX = Board(9, 6, 0.025)


def _facing(centre, distance, roll=0.0, tilt=0.0):
    """T_WC of a camera ``distance`` m from the board point ``centre`` (x, y), looking at it
    along the board's normal turned by ``tilt`` about the board's y axis, rolled by ``roll``."""
    c, s = np.cos(roll), np.sin(roll)
    ct, st = np.cos(tilt), np.sin(tilt)
    R = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]]) @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.array([centre[0], centre[1], 0.0]) - R[:, 2] * distance
    return T


def _board_and_picture():
    """A 9 x 6 board near the camera, and pasted at the image's lower left a small, blurred
    picture of the same board seen from 2.9 m at a slant (squares of about 5 px), JPEG'd."""
    centre = (0.1, 0.0625)
    near = render(K, _facing((0.02, 0.02), 0.45), NINE_BY_SIX, (640, 480), noise_sigma=1.0, rng=1, blur_sigma=1.0)
    far = render(K, _facing(centre, 2.9, roll=0.9, tilt=0.6), NINE_BY_SIX, (640, 480), noise_sigma=2.0, rng=2,
                 blur_sigma=1.5, white=215.0, black=35.0, background=60.0)
    lo = np.floor(np.nanmin(far.junctions, axis=1)).astype(int) - 14
    hi = np.ceil(np.nanmax(far.junctions, axis=1)).astype(int) + 14
    window = far.image[lo[1]:hi[1], lo[0]:hi[0]]
    image = near.image.copy()
    image[470 - window.shape[0]:470, 10:10 + window.shape[1]] = window
    return jpeg_roundtrip(image, 75), near


@pytest.fixture(scope="module")
def left_camera():
    return read_camera(opencv_file("left.opencv.yml"))


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_every_left_sample_refuses_an_8x6_spec_naming_the_9x6_board(left_camera):
    for k in LEFT:
        image = read_image(OPENCV_DIR / f"left{k:02d}.jpg")
        for camera in (left_camera, None):  # with the camera, and as a raw image without one
            with pytest.raises(BoardMismatchError) as exc:
                extract_junctions(image, bounds=None, board=Board(8, 6, 0.025), camera=camera)
            assert exc.value.found == (9, 6), (k, str(exc.value))
            assert "9 x 6" in str(exc.value) and "8 x 6" in str(exc.value)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_command_line_gives_no_pose_and_names_the_board(left_camera):
    """left05.jpg: the small picture on the monitor was taken as the 8 x 6 board (exit 0)."""
    run = subprocess.run([sys.executable, "-m", "graphpose", "estimate", str(opencv_file("left05.jpg")),
                          "--board", "8x6x0.025", "--camera", str(opencv_file("left.opencv.yml"))],
                         capture_output=True, text=True)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "found a 9 x 6 board" in run.stderr and "8 x 6" in run.stderr
    assert "T_WC" not in run.stdout


def test_a_rendered_9x6_board_refuses_an_8x6_spec():
    R = render(K, _facing((0.1, 0.0625), 0.6, roll=0.2), NINE_BY_SIX, (640, 480), rng=3)
    with pytest.raises(BoardMismatchError) as exc:
        extract_junctions(R.image, bounds=None, board=Board(8, 6, 0.025))
    assert exc.value.found == (9, 6) and "found a 9 x 6 board" in str(exc.value)
    J = extract_junctions(R.image, bounds=None, board=NINE_BY_SIX)  # the right spec finds it, on the truth
    assert J.trusted.all() and np.max(np.hypot(*(J.points - R.junctions))) < 0.1


def test_a_small_picture_of_a_board_is_not_taken_for_the_spec_beside_a_larger_board():
    image, near = _board_and_picture()
    with pytest.raises(BoardMismatchError) as exc:
        extract_junctions(image, bounds=None, board=Board(8, 6, 0.025))
    assert exc.value.found == (9, 6) and "found a 9 x 6 board" in str(exc.value)
    J = extract_junctions(image, bounds=None, board=NINE_BY_SIX)  # the right spec: the large board, not the picture
    assert J.trusted.all() and np.max(np.hypot(*(J.points - near.junctions))) < 0.1


def test_a_mismatch_is_a_board_not_found():
    """Callers that skip a view without the board (calibration, tracking, batch) skip it too."""
    assert issubclass(BoardMismatchError, BoardNotFoundError)
    err = BoardMismatchError("found a 9 x 6 board", found=(9, 6), size_px=120.0, junctions_seen=54)
    assert err.found == (9, 6) and err.size_px == 120.0 and err.junctions_seen == 54 and not err.two_boards
