"""graphpose.detect.grid: grid-to-image homographies and the square sizes they give."""

import numpy as np
import pytest

from graphpose import BoardNotFoundError
from graphpose.detect.grid import fit_homography, square_sides


def test_junctions_that_fix_no_homography_mean_no_board():
    one_row = np.array([[0.0, 1, 2, 3, 4, 5], [0, 0, 0, 0, 0, 0]])
    pixels = np.array([[10.0, 20, 30, 40, 50, 60], [5, 6, 7, 8, 9, 10]])
    with pytest.raises(BoardNotFoundError, match="do not fix a homography"):
        fit_homography(one_row, pixels)


def test_fit_homography_recovers_the_map_that_made_the_points_with_h22_one():
    H = np.array([[30.0, 2.0, 100.0], [-1.0, 28.0, 80.0], [1e-3, 2e-3, 1.0]])
    c, r = np.meshgrid(np.arange(6.0), np.arange(4.0))
    grid = np.vstack([c.ravel(), r.ravel()])
    q = H @ np.vstack([grid, np.ones(grid.shape[1])])
    fitted = fit_homography(grid, q[:2] / q[2])
    assert fitted[2, 2] == 1.0
    np.testing.assert_allclose(fitted, H, rtol=1e-8, atol=1e-10)


def test_square_sides_is_the_parallelograms_smaller_height():
    # An affine map: the grid steps are the columns (30, 0) and (10, 20); the parallelogram
    # has area 30 * 20 = 600 and longer side 30, so its smaller height is 20 everywhere.
    H = np.array([[30.0, 10.0, 5.0], [0.0, 20.0, 7.0], [0.0, 0.0, 1.0]])
    grid = np.array([[0.0, 3.0, -2.0, 7.5], [0.0, 1.0, 4.0, -3.0]])
    np.testing.assert_allclose(square_sides(H, grid), 20.0, rtol=1e-12)
    # A square grid turned and scaled by 12 px: squares of 12 px.
    a = 0.4
    turn = np.array([[12 * np.cos(a), -12 * np.sin(a), 50.0], [12 * np.sin(a), 12 * np.cos(a), 60.0], [0, 0, 1]])
    np.testing.assert_allclose(square_sides(turn, grid), 12.0, rtol=1e-12)
    # Through a perspective map, the image twice as large has squares twice as large.
    P = np.array([[30.0, 2.0, 100.0], [-1.0, 28.0, 80.0], [1e-2, 2e-2, 1.0]])
    sides = square_sides(P, grid)
    np.testing.assert_allclose(square_sides(np.diag([2.0, 2.0, 1.0]) @ P, grid), 2 * sides, rtol=1e-12)
    assert np.ptp(sides) > 1.0  # perspective: the squares differ in size across the grid
