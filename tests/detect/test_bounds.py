"""Bounds name junction 0 on every board, whatever its colours say; the colour rule orders
boards found without bounds; bounds a quarter turn off are refused; ``junction0_square`` says
which colour junction 0's outer corner square has."""

import numpy as np
import pytest

from graphpose import Board, BoardNotFoundError, extract_junctions, read_image
from graphpose.io.cameras import read_camera
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render
from tests.conftest import PROJECT_K as K
from tests.conftest import opencv_file

OPENCV_BOARD = Board(9, 6, 0.03)
SAMPLES = [f"{side}{k:02d}.jpg" for side in ("left", "right") for k in (1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14)]


def corner_cycle(J, board):
    """The board's four outer corners, half a square beyond the corner junctions along both
    grid directions, in the cycle of junctions 0, cols - 1, n - 1, (rows - 1) cols (clockwise
    in the image: the labels are right-handed), from the detector's own junctions."""
    P = J.points.reshape(2, board.rows, board.cols)
    out = []
    for r, c, dr, dc in ((0, 0, 1, 1), (0, board.cols - 1, 1, -1), (board.rows - 1, board.cols - 1, -1, -1),
                         (board.rows - 1, 0, -1, 1)):
        p = P[:, r, c]
        out.append(p - 0.5 * (P[:, r, c + dc] - p) - 0.5 * (P[:, r + dr, c] - p))
    return np.array(out).T


def user_bounds(J, board):
    """Bounds as a user draws them: clockwise, first edge along a row (of ``cols`` junctions),
    from the one of the two such corners nearest the image's upper left; and the shift of the
    detector's cycle it is (0, or 2: the board is turned by more than 90 degrees)."""
    cycle = corner_cycle(J, board)
    shift = min((0, 2), key=lambda s: np.hypot(*cycle[:, s]))
    return np.roll(cycle, -shift, axis=1), shift


@pytest.fixture(scope="module")
def samples():
    cameras = {"left": read_camera(opencv_file("left.opencv.yml")), "right": read_camera(opencv_file("right.opencv.xml"))}
    out = []
    for name in SAMPLES:
        camera = cameras["left" if name.startswith("left") else "right"]
        image = read_image(opencv_file(name))
        out.append((name, image, camera, extract_junctions(image, bounds=None, board=OPENCV_BOARD, camera=camera)))
    return out


@pytest.mark.slow  # every OpenCV sample at four bounds each
def test_bounds_from_the_corner_nearest_the_upper_left_find_every_opencv_sample_with_junction_0_there(samples):
    turned = []
    for name, image, camera, free in samples:
        assert free.junction0_square == "dark", name  # without bounds: the colour rule
        bounds, shift = user_bounds(free, OPENCV_BOARD)
        J = extract_junctions(image, bounds=bounds, board=OPENCV_BOARD, camera=camera)
        assert J.trusted.all() and J.seen.all() and not J.orientation_ambiguous, name
        corners = J.points[:, [0, OPENCV_BOARD.cols - 1, OPENCV_BOARD.n - 1, OPENCV_BOARD.n - OPENCV_BOARD.cols]]
        nearest = np.argmin(np.hypot(bounds[0][:, None] - corners[0], bounds[1][:, None] - corners[1]), axis=1)
        assert np.array_equal(nearest, np.arange(4)), name  # junction 0 at vertex 0, and round the board
        # The same junctions, relabelled by the half turn where the bounds named the other corner.
        expected = free.points if shift == 0 else free.points[:, ::-1]
        np.testing.assert_allclose(J.points, expected, atol=1e-6, err_msg=name)
        assert J.junction0_square == ("dark" if shift == 0 else "light"), name
        if shift:
            turned.append(name)
    assert len(turned) >= 3  # boards turned by more than 90 degrees: once refused (5 of these 26)


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_bounds_a_quarter_turn_off_are_refused_and_say_so(samples):
    name, image, camera, free = next(s for s in samples if s[0] == "left05.jpg")
    bounds, _ = user_bounds(free, OPENCV_BOARD)
    for shift in (1, 3):  # the first edge along a column (6 junctions) of the 9 x 6 board
        with pytest.raises(BoardNotFoundError, match=r"quarter turn off .*along a column of the 9 x 6 board"):
            extract_junctions(image, bounds=np.roll(bounds, -shift, axis=1), board=OPENCV_BOARD, camera=camera)


@pytest.mark.parametrize("board, opposite", [(Board(9, 6, 0.03), "light"), (Board(8, 6, 0.0635), "dark"),
                                             (Board(7, 5, 0.05), "dark")])
def test_junction0_square_is_the_colour_rendered_at_junction_0s_corner(board, opposite):
    # Rendered boards: junction 0's outer square is dark (the upper-left square); the corner
    # diagonally opposite is light on 9 x 6 (10 x 7 squares) and dark on 8 x 6 and 7 x 5.
    rng = np.random.default_rng(4)
    R = render(K, random_pose(K, board, rng=rng), board, rng=rng)
    poly = loose_polygon(R, rng=rng)
    J = extract_junctions(R.image, bounds=poly, board=board)
    assert J.junction0_square == "dark" and J.trusted.all()
    np.testing.assert_allclose(J.points, R.junctions, atol=0.1)
    free = extract_junctions(R.image, bounds=None, board=board)
    assert free.junction0_square == "dark"
    # Bounds that start at the opposite corner name it junction 0: the truth turned by half a turn.
    J = extract_junctions(R.image, bounds=np.roll(poly, -2, axis=1), board=board)
    assert J.junction0_square == opposite and J.trusted.all() and not J.orientation_ambiguous
    np.testing.assert_allclose(J.points, R.junctions[:, ::-1], atol=0.1)
