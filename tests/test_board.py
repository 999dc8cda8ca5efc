"""The checkerboard target: junction grid, sheet, parsing, and recovery from its points."""

import json

import numpy as np
import pytest

from graphpose import Board, InputError
from tests.conftest import REAL_DIR


def test_board_world_points_and_parse():
    b = Board()
    W = b.world_points()
    assert W.shape == (3, 48)
    np.testing.assert_allclose(W[:, 9], [0.0635, 0.0635, 0.0])
    assert Board.parse("9x7x0.03") == Board(9, 7, 0.03)
    assert Board.from_world_points(W) == b
    with pytest.raises(InputError, match="COLSxROWS"):
        Board.parse("8x6")
    with pytest.raises(InputError, match="grid"):
        Board.from_world_points(W[:, ::-1])


def test_grid_indices_are_row_major():
    np.testing.assert_array_equal(Board(3, 2).grid_indices(), [[0, 1, 2, 0, 1, 2], [0, 0, 0, 1, 1, 1]])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"cols": 1}, "Board cols must be an integer >= 2, got 1"),
        ({"rows": 2.0}, "Board rows must be an integer >= 2, got 2.0"),
        ({"cols": True}, "Board cols must be an integer >= 2, got True"),
        ({"square_m": 0.0}, r"Board square_m \(metres\) must be a finite number > 0, got 0.0"),
        ({"square_m": -0.1}, "square_m .* must be a finite number > 0"),
        ({"square_m": np.inf}, "square_m .* must be a finite number > 0"),
        ({"square_m": "0.1"}, "square_m .* must be a finite number > 0, got '0.1'"),
        ({"square_m": [0.1, 0.2]}, r"square_m .* must be a finite number > 0, got \[0.1, 0.2\]"),
    ],
)
def test_board_rejects(kwargs, message):
    with pytest.raises(InputError, match=message):
        Board(**kwargs)


def test_board_from_world_points_rejects_a_partial_grid():
    W = Board().world_points()
    with pytest.raises(InputError, match="47 points is not a full row-major grid"):
        Board.from_world_points(W[:, :47])  # last row one junction short
    with pytest.raises(InputError, match="starting at the upper-left junction"):
        Board.from_world_points(W + [[0.01], [0.0], [0.0]])
    with pytest.raises(InputError, match=r"Wpts must have shape \(3, N\)"):
        Board.from_world_points(W[:2])
    with pytest.raises(InputError, match="Wpts needs at least 4 points"):
        Board.from_world_points(W[:, :3])
    with pytest.raises(InputError, match="NaN"):
        Board.from_world_points(np.where(W == W[0, 5], np.nan, W))
    with pytest.raises(InputError, match="Wpts must be a rectangular array"):
        Board.from_world_points([[0.0, 1.0], [0.0]])


def test_sheet_corners_border_the_squares_clockwise():
    b = Board(4, 3, 0.5)
    np.testing.assert_array_equal(b.sheet_corners(0.0), [[-0.5, 2.0, 2.0, -0.5], [-0.5, -0.5, 1.5, 1.5], [0, 0, 0, 0]])
    np.testing.assert_array_equal(
        b.sheet_corners(), [[-0.75, 2.25, 2.25, -0.75], [-0.75, -0.75, 1.75, 1.75], [0, 0, 0, 0]])
    per_corner = b.sheet_corners([0.0, 1.0, 2.0, 3.0])
    np.testing.assert_array_equal(per_corner[:2], [[-0.5, 2.5, 3.0, -2.0], [-0.5, -1.0, 2.5, 3.0]])


@pytest.mark.parametrize("margin", [-0.1, np.nan, [0.5, 0.5], "wide"])
def test_sheet_corners_rejects_bad_margin(margin):
    with pytest.raises(InputError, match="margin must be"):
        Board().sheet_corners(margin)


def test_real_world_points_match_board(real_cases):
    W = np.asarray(json.loads((REAL_DIR / "cases.json").read_text())["world_points"])
    assert real_cases.board == Board()
    np.testing.assert_allclose(Board.from_world_points(W).world_points(), W, atol=1e-12)


# --- units of the square's side (issue 26) ---------------------------------------------------


@pytest.mark.parametrize("text", ["9x6x0.025", "9x6x25mm", "9x6x2.5cm", "9x6x0.025m", "9X6X25MM", " 9x6x25 mm "])
def test_board_spec_takes_metres_millimetres_and_centimetres(text):
    assert Board.parse(text) == Board(9, 6, 0.025)
    assert Board.parse(text).square_m == 0.025  # exactly: the unit divides
    assert Board.parse("8x6x63.5mm").square_m == Board().square_m


def test_a_bare_side_over_one_metre_is_taken_for_millimetres_and_refused():
    with pytest.raises(InputError, match=r"did you mean 25 mm \(0\.025\)\? \(write 9x6x25mm or 9x6x0\.025\)"):
        Board.parse("9x6x25")
    with pytest.raises(InputError, match=r"Board square_m is 25 m, over 1 m: did you mean 25 mm \(0\.025\)\?.*allow_large"):
        Board(9, 6, 25.0)
    assert Board.parse("9x6x1") == Board(9, 6, 1.0)  # 1 m itself is a (large) board


def test_allow_large_takes_a_wall_sized_board_and_is_not_part_of_its_identity():
    big = Board(9, 6, 1.5, allow_large=True)
    assert big.world_points()[0, 1] == 1.5
    assert Board.parse("9x6x1.5", allow_large=True) == big
    assert repr(big) == "Board(cols=9, rows=6, square_m=1.5)"
    with pytest.raises(InputError, match="board must look like COLSxROWSxSQUARE_M"):
        Board.parse("9x6x25inch")


def test_warp_basis_is_mrcals_parabolas():
    b = Board(9, 6, 0.025)
    W = b.world_points()
    basis = b.warp_basis(W)
    assert basis.shape == (2, b.n)
    c, r = b.grid_indices()
    # mrcal's 4 x_r (1 - x_r), x_r from 0 at the first junction to 1 at the last.
    xr, yr = c / (b.cols - 1), r / (b.rows - 1)
    np.testing.assert_allclose(basis, np.stack([4 * xr * (1 - xr), 4 * yr * (1 - yr)]), atol=1e-12)
    assert np.all(basis[:, [0, b.cols - 1, b.n - b.cols, b.n - 1]] == 0)  # the corners do not move
    centre = 2 * b.cols + 4  # column 4 of 0..8, row 2 of 0..5: x at the middle
    assert basis[0, centre] == pytest.approx(1.0)
    bent = b.warped(W, (0.002, 0.001))
    np.testing.assert_allclose(bent[:2], W[:2])
    np.testing.assert_allclose(bent[2], 0.002 * basis[0] + 0.001 * basis[1])
    np.testing.assert_array_equal(b.warped(W, None), W)
    with pytest.raises(InputError, match="warp"):
        b.warped(W, (0.001,))
