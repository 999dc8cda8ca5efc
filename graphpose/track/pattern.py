"""The board's square pattern in a frame: where a missed prediction should have been, and
whether a labelling is the only one the visible board allows.

The tracker's refinement starts from the predicted junctions and converges only within about
half a square of them. In a whip pan the constant-velocity prediction can miss by more than
that (a board moving 40-130 px a frame, its squares 50-65 px). The board's squares are still
in the frame, smeared by the motion along one direction but each keeping its colour at its
centre; this module reads them there.

A **cell** is a square of the board's pattern and of its continuation beyond the board:
cell ``(i, j)`` covers ``[i s, (i + 1) s] x [j s, (j + 1) s]`` in the target frame (``s`` the
square side), so the board's own squares are ``i = -1 .. cols - 1``, ``j = -1 .. rows - 1``
(:meth:`graphpose.board.Board.sheet_corners`), its ring the cells next to them, and farther
cells the margin and the scene. A cell's value is the mean grey of five image samples (its
centre and four points 0.22 squares from it, bilinear), NaN when any falls outside the image.

1. :func:`pattern_shift`: the image translation, within about a square, that puts the
   predicted squares on squares of the same colour (the best correlation of the board's
   ``+-1`` pattern with the cells' values); the prediction's junctions moved by it are where
   the refinement starts again.
2. :func:`labelling_gap`: how much better the labelling of a pose explains the cells than
   every other placement of the board on the same grid of cells. Each placement (the board
   moved by ``(a, b)`` whole squares, every shift that leaves some of it on a visible cell) is
   fitted by least squares to the visible cells: its squares as ``m + c q`` (``q`` the
   pattern's ``+-1``, with the sign the board shows in the tracked frames, ``c >= 0``), its
   ring as one unknown grey (the margin, whatever its width), every farther cell as another
   (the scene). A placement one square off puts squares of the wrong colour on the board; two
   squares off, or one diagonally, it calls the continued pattern beyond a visible edge of
   the board "scene" (or the margin "squares"), and its residual grows by about ``c^2`` a
   cell. The gap is the smallest increase over the pose's own residual, in units of its
   ``c^2``: about the number of cells that tell the labelling apart. Where no edge of the
   board is in view, every placement fits as well and the gap is about 0: the labelling is
   not to be trusted.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates

from ..board import Board
from ..geometry import to_camera

#: Least evidence (about the cells that tell them apart, :func:`labelling_gap`) by which a
#: realigned labelling must beat every other placement of the board.
MIN_LABEL_GAP = 4.0
#: Largest mean squared residual of the realigned board's squares over their squared contrast
#: (:func:`labelling_gap`'s ``fit``): beyond it the squares do not show their pattern.
MAX_PATTERN_SPREAD = 0.5

#: Fewest of the board's squares a translation must leave wholly in the image to be scored.
MIN_SQUARES = 8

#: Offsets of a cell's five samples from its centre, squares.
_SAMPLES = np.array([[0.0, 0.22, -0.22, 0.0, 0.0], [0.0, 0.0, 0.0, 0.22, -0.22]])


class BoardCells:
    """The cells of a board and of its continuation, and the placements to compare.

    Parameters
    ----------
    board : Board
        The target.
    reach : int
        Cells beyond the board's squares on every side, >= 2: every placement of the board
        that overlaps the board's own squares is compared (``cols + 2`` is all of them).
    """

    def __init__(self, board: Board, reach: int | None = None):
        self.board = board
        if reach is None:
            reach = max(board.cols, board.rows) + 2
        cols, rows = board.cols + 1, board.rows + 1  # squares a row, a column
        i = np.arange(-1 - reach, cols - 1 + reach)
        j = np.arange(-1 - reach, rows - 1 + reach)
        jj, ii = np.meshgrid(j, i, indexing="ij")
        self.i, self.j = ii.ravel(), jj.ravel()
        self.pattern = np.where((self.i + self.j) % 2 == 0, -1.0, 1.0)  # -1 (dark) at the upper-left square
        s = board.square_m
        centres = np.vstack([(self.i + 0.5) * s, (self.j + 0.5) * s])
        pts = centres[:, :, None] + s * _SAMPLES[:, None, :]
        self.points = np.vstack([pts.reshape(2, -1), np.zeros((1, pts[0].size))])  # (3, 5 * cells)
        self.on_board = (self.i >= -1) & (self.i <= cols - 2) & (self.j >= -1) & (self.j <= rows - 2)
        # The board's squares sampled evenly over their area (4 x 4 points each): their
        # correlation with the pattern peaks where they sit exactly on their squares (five
        # points about the centre would stay on their squares over a plateau a half square wide).
        grid = (np.arange(4) - 1.5) / 4
        area = np.array(np.meshgrid(grid, grid)).reshape(2, -1)
        pts = centres[:, self.on_board, None] + s * area[:, None, :]
        self.area_points = np.vstack([pts.reshape(2, -1), np.zeros((1, pts[0].size))])  # (3, 16 * squares)
        self.square_points = self.points.reshape(3, -1, 5)[:, self.on_board].reshape(3, -1)  # (3, 5 * squares)
        # Placements: shifts (a, b) in squares; the board's squares then cover cells
        # i - a in [-1, cols - 2], j - b in [-1, rows - 2].
        span = max(reach - 1, 1)
        self.shifts = [(a, b) for b in range(-min(span, rows + 1), min(span, rows + 1) + 1)
                       for a in range(-min(span, cols + 1), min(span, cols + 1) + 1) if (a, b) != (0, 0)]
        self._index = {(a, b): k for k, (a, b) in enumerate(zip(self.i, self.j))}

    def pixels(self, camera, T_WC, area: bool = False) -> np.ndarray:
        """Image positions (2, 5, cells) of every cell's samples seen from ``T_WC``, or with
        ``area`` (2, 16, squares) of the board's squares' area samples (NaN behind the camera)."""
        P = to_camera(T_WC, self.area_points if area else self.points)
        with np.errstate(invalid="ignore", divide="ignore"):
            uv = camera.project(P)
        uv[:, P[2] <= 1e-6] = np.nan
        m = 16 if area else 5
        return uv.reshape(2, -1, m).transpose(0, 2, 1)


def cell_values(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Mean grey of each cell's samples at ``uv`` (2, 5, cells); NaN where a sample leaves the image."""
    h, w = image.shape
    u, v = uv[0], uv[1]
    inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)
    vals = map_coordinates(image, [np.where(inside, v, 0.0).ravel(), np.where(inside, u, 0.0).ravel()],
                           order=1, mode="nearest").reshape(u.shape)
    out = vals.mean(axis=0)
    out[~inside.all(axis=0)] = np.nan
    return out


def board_contrast(image, cells: BoardCells, camera, T_WC) -> float:
    """:func:`pattern_contrast` of the board's own squares seen from ``T_WC`` (the cheap check
    of a tracked frame: a labelling one square off inverts it)."""
    P = to_camera(T_WC, cells.square_points)
    with np.errstate(invalid="ignore", divide="ignore"):
        uv = camera.project(P)
    uv[:, P[2] <= 1e-6] = np.nan
    values = np.full(cells.i.size, np.nan)
    values[cells.on_board] = cell_values(image, uv.reshape(2, -1, 5).transpose(0, 2, 1))
    return pattern_contrast(cells, values)


def pattern_contrast(cells: BoardCells, values: np.ndarray) -> float:
    """The board's contrast in the cells' values, signed: half the difference of its light and
    dark squares' mean grey, positive when the board shows the cells' pattern as it is (dark
    at the upper-left square), negative when inverted; 0 when fewer than four of its squares
    are in view."""
    keep = cells.on_board & np.isfinite(values)
    if np.count_nonzero(keep) < 4:
        return 0.0
    x, q = values[keep], cells.pattern[keep]
    if (q > 0).all() or (q < 0).all():
        return 0.0
    return float((x[q > 0].mean() - x[q < 0].mean()) / 2.0)


def pattern_shift(image, cells: BoardCells, camera, T_pred, sign: float, side_px: float,
                  reach: float = 0.9, step: float = 0.1, min_score: float = 0.0):
    """The image translation that best puts the predicted board's squares on squares of their colour.

    Parameters
    ----------
    image : (H, W) ndarray
        The frame.
    cells : BoardCells
        The board's cells.
    camera : Camera
        The camera (:mod:`graphpose.camera_models`).
    T_pred : (4, 4) ndarray
        The predicted pose T_WC.
    sign : float
        The board's polarity, +-1 (the sign of :func:`pattern_contrast`).
    side_px : float
        The predicted square side, pixels.
    reach, step : float
        Translations searched: every multiple of ``step`` squares within ``reach`` squares,
        then every quarter step within 1.5 steps of the best.
    min_score : float
        Least correlation (grey levels: the board's contrast where it sits on its squares)
        of the coarse search's best translation.

    Returns
    -------
    (2,) ndarray or None
        The translation, pixels (u, v); None when no translation leaves
        :data:`MIN_SQUARES` of the board's squares in the image, or the best correlates less
        than ``min_score``.
    """
    on = cells.on_board
    q = sign * cells.pattern[on]
    n = int(round(reach / step))
    grid = np.arange(-n, n + 1) * step * side_px
    du, dv = np.meshgrid(grid, grid)
    keep = np.hypot(du, dv) <= reach * side_px + 1e-9
    # Coarse: the squares' five samples about their centres (a plateau a half square wide
    # where they stay on their squares, found at any of its offsets); fine: their area.
    best, score = _best_offset(image, cells.pixels(camera, T_pred)[:, :, on], q, np.vstack([du[keep], dv[keep]]))
    if best is None or score < min_score:
        return None
    fine = np.arange(-6, 7) * step * side_px / 4
    du, dv = np.meshgrid(fine, fine)
    best, _ = _best_offset(image, cells.pixels(camera, T_pred, area=True), q,
                           best[:, None] + np.vstack([du.ravel(), dv.ravel()]))
    return best


def _best_offset(image, board_uv, q, offsets):
    """Of ``offsets`` (2, T), pixels, the one whose moved board squares' samples ``board_uv``
    (2, m, squares) correlate best with their pattern ``q``, and its correlation (grey
    levels); (None, -inf) when none leaves :data:`MIN_SQUARES` squares in the image."""
    h, w = image.shape
    moved = board_uv[:, None] + offsets[:, :, None, None]  # (2, T, m, squares)
    u, v = moved[0], moved[1]
    inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)
    vals = map_coordinates(image, [np.where(inside, v, 0.0).ravel(), np.where(inside, u, 0.0).ravel()],
                           order=1, mode="nearest").reshape(u.shape).mean(axis=1)  # (T, cells)
    ok = inside.all(axis=1)
    count = ok.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(ok, vals, 0.0).sum(axis=1) / count
        score = np.where(ok, (vals - mean[:, None]) * q, 0.0).sum(axis=1) / count
    score[count < MIN_SQUARES] = -np.inf
    best = int(np.argmax(score))
    if not np.isfinite(score[best]):
        return None, -np.inf
    return offsets[:, best], float(score[best])


def labelling_gap(cells: BoardCells, values: np.ndarray, sign: float) -> tuple:
    """How much better the labelling explains the cells than every other placement of the board.

    Parameters
    ----------
    cells : BoardCells
        The board's cells.
    values : (cells,) ndarray
        Their grey values seen from the pose under test (:func:`cell_values`), NaN out of view.
    sign : float
        The board's polarity, +-1 (the sign of :func:`pattern_contrast`).

    Returns
    -------
    gap : float
        The smallest residual increase of another placement over the labelling's own, in
        units of the labelling's squared contrast ``c^2`` (about the cells that tell them
        apart); -inf when the labelling's own contrast is not positive.
    fit : float
        The labelling's mean squared residual on its visible squares over ``c^2`` (about 0 for
        sharp squares; grows with blur and noise).
    """
    seen = np.isfinite(values)
    x, i, j, q = values[seen], cells.i[seen], cells.j[seen], sign * cells.pattern[seen]
    own, c, fit = _placement_rss(cells, x, i, j, q, 0, 0)
    if not c > 0:
        return -np.inf, np.inf
    gap = min(_placement_rss(cells, x, i, j, q, a, b)[0] for a, b in cells.shifts) - own
    return gap / c ** 2, fit


def _placement_rss(cells, x, i, j, q, a, b):
    """Least-squares residual of the board placed ``(a, b)`` squares over on the visible
    cells (values ``x`` at cells ``i, j`` with pattern ``q``): (rss, c, board mean squared
    residual over c^2)."""
    cols, rows = cells.board.cols + 1, cells.board.rows + 1
    ii, jj = i - a, j - b
    board = (ii >= -1) & (ii <= cols - 2) & (jj >= -1) & (jj <= rows - 2)
    ring = ~board & (ii >= -2) & (ii <= cols - 1) & (jj >= -2) & (jj <= rows - 1)
    far = ~board & ~ring
    qb = q[board] * (-1.0 if (a + b) % 2 else 1.0)  # the pattern's colour where the moved board lies
    xb = x[board]
    rss = 0.0
    c = 0.0
    fit = np.inf
    if xb.size:
        light, dark = xb[qb > 0], xb[qb < 0]
        if light.size and dark.size:
            c = max((light.mean() - dark.mean()) / 2.0, 0.0)
            m = (light.mean() + dark.mean()) / 2.0
        else:
            m = xb.mean()
        r = xb - m - c * qb
        rss += float(r @ r)
        if c > 0:
            fit = float(r @ r) / (xb.size * c ** 2)
    for part in (ring, far):
        xp = x[part]
        if xp.size:
            r = xp - xp.mean()
            rss += float(r @ r)
    return rss, c, fit
