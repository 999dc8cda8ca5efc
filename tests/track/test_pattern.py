"""The board's square pattern in a frame: graphpose.track.pattern."""

import numpy as np
import pytest

from graphpose import Board, T_from_params
from graphpose.camera_models import as_camera
from graphpose.synth.render import render
from graphpose.track.pattern import (MAX_PATTERN_SPREAD, MIN_LABEL_GAP, BoardCells, board_contrast, cell_values,
                                     labelling_gap, pattern_contrast, pattern_shift)
from tests.conftest import PROJECT_K as K

BOARD = Board()
S = BOARD.square_m
CAMERA = as_camera(K)


def _moved(T_WC, a, b):
    """The pose that sees board point p where ``T_WC`` sees p + (a, b) squares: the labelling
    moved by whole squares."""
    shift = np.eye(4)
    shift[:2, 3] = [-a * S, -b * S]
    return shift @ T_WC


def _view(x, y, z, yaw=0.05, seed=1):
    T = T_from_params([x, y, z, 0.08, -0.1, yaw])
    return T, render(K, T, BOARD, noise_sigma=4.0, rng=seed, blur_sigma=1.5).image


@pytest.fixture(scope="module")
def cells():
    return BoardCells(BOARD)


def _gap(cells, image, T, sign):
    return labelling_gap(cells, cell_values(image, cells.pixels(CAMERA, T)), sign)


def test_a_partly_visible_boards_edges_fix_its_labels(cells):
    # The board 0.75 m away, its left columns beyond the image: its right, top and bottom
    # edges in view. The true labelling beats every other placement by many cells; a labelling one
    # square over, or one diagonally, or two over, explains the cells worse than the truth.
    T, image = _view(0.5, 0.17, -0.75)
    contrast = pattern_contrast(cells, cell_values(image, cells.pixels(CAMERA, T)))
    assert contrast == pytest.approx(90.0, abs=10)  # the upper-left square dark, as the cells' pattern
    sign = np.sign(contrast)
    gap, spread = _gap(cells, image, T, sign)
    assert gap > 2 * MIN_LABEL_GAP and spread < MAX_PATTERN_SPREAD
    for a, b in [(1, 0), (0, 1), (1, 1), (-1, 1), (2, 0), (0, -2)]:
        assert _gap(cells, image, _moved(T, a, b), sign)[0] < 0, (a, b)


def test_no_edge_in_view_leaves_the_labels_unfixed(cells):
    # Close up at the board's middle: only inner squares in view, every placement fits as
    # well, and the gap says so (the tracker then does not trust a realigned labelling).
    T, image = _view(0.25, 0.19, -0.17)
    sign = np.sign(pattern_contrast(cells, cell_values(image, cells.pixels(CAMERA, T))))
    gap, _ = _gap(cells, image, T, sign)
    assert gap < MIN_LABEL_GAP


def test_pattern_contrast_reads_an_inverted_board(cells):
    T, image = _view(0.25, 0.19, -0.6)
    c = pattern_contrast(cells, cell_values(image, cells.pixels(CAMERA, T)))
    assert c > 50
    assert pattern_contrast(cells, cell_values(255 - image, cells.pixels(CAMERA, T))) == pytest.approx(-c, abs=1e-9)
    assert pattern_contrast(cells, np.full(len(cells.i), np.nan)) == 0.0


@pytest.mark.parametrize("miss", [(0.6, 0.0), (-0.45, 0.3), (0.0, -0.7)])
def test_pattern_shift_finds_where_a_missed_prediction_should_have_been(cells, miss):
    # The prediction misses by up to 0.7 squares (beyond the refinement's reach): the shift
    # puts the predicted junctions back within a tenth of a square of the true ones.
    T, image = _view(0.3, 0.2, -0.6)
    T_pred = _moved(T, *miss)
    true_uv = CAMERA.project((np.linalg.inv(T) @ np.vstack([BOARD.world_points(), np.ones(BOARD.n)]))[:3])
    pred_uv = CAMERA.project((np.linalg.inv(T_pred) @ np.vstack([BOARD.world_points(), np.ones(BOARD.n)]))[:3])
    side = float(np.median(np.hypot(*(true_uv[:, 1:8] - true_uv[:, :7]))))
    shift = pattern_shift(image, cells, CAMERA, T_pred, 1.0, side)
    error = np.hypot(*(pred_uv + shift[:, None] - true_uv))
    assert np.median(error) < 0.05 * side


def test_pattern_shift_without_the_board_in_view(cells):
    T, image = _view(3.0, 3.0, -0.6)
    assert pattern_shift(image, cells, CAMERA, T, 1.0, 50.0) is None
    # The board out of view, the prediction where it was: no pattern there.
    T, _ = _view(0.3, 0.2, -0.6)
    blank = np.full((480, 640), 60, dtype=np.uint8)
    assert pattern_shift(blank, cells, CAMERA, T, 1.0, 57.0, min_score=20.0) is None


def test_board_contrast_is_inverted_by_a_labelling_one_square_off(cells):
    # The tracked frame's cheap check: the board's own squares only, the same contrast as
    # the whole cell grid's; a labelling one square over (along a row or a column) inverts it,
    # one diagonally does not (the test of the full placement comparison is needed there).
    T, image = _view(0.25, 0.19, -0.6)
    c = board_contrast(image, cells, CAMERA, T)
    assert c == pytest.approx(pattern_contrast(cells, cell_values(image, cells.pixels(CAMERA, T))), rel=1e-12)
    assert c > 50
    assert board_contrast(image, cells, CAMERA, _moved(T, 1, 0)) < -0.5 * c
    assert board_contrast(image, cells, CAMERA, _moved(T, 0, -1)) < -0.5 * c
    assert board_contrast(image, cells, CAMERA, _moved(T, 1, 1)) > 0.5 * c
