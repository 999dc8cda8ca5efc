"""Cross-junctions of the checkerboard, to sub-pixel accuracy, in row-major order.

Coarse localisation (:mod:`.grid`) finds the grid through the bounds' homography;
refinement (:mod:`.refine`) fits a saddle at every junction; this module decides which
junctions to trust and returns them as :class:`Junctions`.

Coordinates follow :mod:`graphpose.camera`: ``(u, v)`` pixels, 0-based, 2 x N arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import check_bounds, check_number
from ..board import Board
from ..errors import BoardNotFoundError
from .grid import apply_homography, fit_homography, locate_grid, square_sides
from .refine import (
    MAX_RADIUS,
    SMOOTH_SIGMA,
    WINDOW_FRACTION,
    grey_and_scale,
    refine_points,
)

#: Smallest image side, pixels: the smallest refinement window (radius 2) must fit, and the
#: bilinear resampling needs two rows and columns.
_MIN_SIDE = 5

#: A junction whose refined position is farther than this from the grid homography's
#: prediction (fraction of the local square, or 1.5 px if more) is not trusted.
_GRID_TOLERANCE = 0.08

#: A junction whose fit residual exceeds this multiple of the board's median is not trusted
#: (the six real images stay within 0.85-1.14 of their medians).
_RESIDUAL_RATIO = 1.5



@dataclass(frozen=True)
class Junctions:
    """Cross-junctions found in one image.

    Attributes
    ----------
    points : (2, n) ndarray of float64
        Junction positions (u, v), pixels, row-major from the upper-left junction.
    trusted : (n,) ndarray of bool
        True where the saddle fit converged to a saddle inside its window, the window lies
        inside the image, a ring around the point looks like a cross-junction, its fit
        residual is at most 1.5 times the board's median, and the point agrees with the
        homography fitted to the trusted junctions (within 8 % of the square or 1.5 px).
        Untrusted points are still the best estimate available (refined, or predicted by
        the grid where refinement failed); a pose should use the trusted ones.
    residual : (n,) ndarray of float64
        RMS residual of the saddle quadric under its fit weights (which sit on the two
        edges near the junction), in grey units of the image scaled to [0, 1] (as
        :func:`graphpose.image.as_grey`); NaN where the fit failed.
    square_px : (n,) ndarray of float64
        Local square side at each junction, pixels (the smaller height of the parallelogram
        spanned by the grid steps there).
    homography : (3, 3) ndarray of float64
        Grid-to-image homography fitted to the trusted junctions: grid ``(c, r, 1)`` maps to
        ``(u, v, 1)`` up to scale.
    """

    points: np.ndarray
    trusted: np.ndarray
    residual: np.ndarray
    square_px: np.ndarray
    homography: np.ndarray



def cross_junctions(I, bpoly, Wpts) -> np.ndarray:
    """Cross-junctions of a checkerboard image, row-major from the upper left.

    Parameters
    ----------
    I : (H, W) or (H, W, 3|4) array_like
        The image; colour and 16-bit images are converted by :func:`graphpose.image.as_grey`.
    bpoly : (2, 4) array_like
        Bounding polygon of the board, pixels, clockwise from the upper left; its first
        vertex is the one nearest the upper-left junction and its first edge runs along a
        row of the board. It may be loose: a few pixels outside the sheet or inside its
        white margin.
    Wpts : (3, n) array_like
        The junctions' target-frame points, metres, a full row-major grid as made by
        :meth:`graphpose.board.Board.world_points` (only their grid layout is used).

    Returns
    -------
    Ipts : (2, n) ndarray of float64
        Junction positions (u, v), pixels, in the order of ``Wpts``.

    Raises
    ------
    InputError
        If the image, polygon or ``Wpts`` is malformed (see :func:`extract_junctions`).
    BoardNotFoundError
        If the grid of junctions cannot be found inside the polygon.
    """
    return extract_junctions(I, bpoly, Board.from_world_points(Wpts)).points



def extract_junctions(I, bounds, board: Board = Board(), *, window: float = WINDOW_FRACTION,
                      smooth_sigma: float = SMOOTH_SIGMA) -> Junctions:
    """Find and refine all cross-junctions of a checkerboard inside a bounding polygon.

    Parameters
    ----------
    I : (H, W) or (H, W, 3|4) array_like
        The image (uint8, uint16, bool or float; colour converted to grey).
    bounds : (2, 4) array_like
        Bounding polygon, pixels, as in :func:`cross_junctions`.
    board : Board
        The target's junction grid (``cols`` along the polygon's first edge).
    window : float
        Refinement window radius as a fraction of the local square side, in (0, 0.7].
    smooth_sigma : float
        Gaussian smoothing of refinement patches, pixels (>= 0).

    Returns
    -------
    Junctions
        Points (2, n) row-major, trust mask, fit residuals, local square sizes and the
        grid-to-image homography.

    Raises
    ------
    InputError
        If the image is empty, smaller than 5 x 5 pixels, not 2-D grey or colour, or holds
        NaN; if ``bounds`` is not a finite 2 x 4 array, is degenerate, not convex, counter-clockwise, or lies off the
        image; if ``window`` or ``smooth_sigma`` is out of range.
    BoardNotFoundError
        If no ``cols x rows`` grid of cross-junctions is found inside the polygon, or fewer
        than half of the junctions can be refined and trusted.

    Examples
    --------
    >>> from graphpose import read_image, load_cases, extract_junctions
    >>> cases = load_cases("../shared/data/rob501/cases.json")        # doctest: +SKIP
    >>> case = cases.cases[0]                                          # doctest: +SKIP
    >>> J = extract_junctions(read_image(case.image), case.bounds)     # doctest: +SKIP
    >>> J.points.shape, J.trusted.all()                                # doctest: +SKIP
    ((2, 48), True)
    """
    image, scale = grey_and_scale(I, _MIN_SIDE)
    poly = check_bounds(bounds, image.shape)
    window = check_number("window (a fraction of the square)", window, 0.0, strict=True, maximum=0.7)
    smooth_sigma = check_number("smooth_sigma", smooth_sigma, 0.0)
    H_grid = locate_grid(image, poly, board)
    grid = board.grid_indices().astype(float)
    coarse = apply_homography(H_grid, grid)
    square = square_sides(H_grid, grid)
    radius = np.minimum(window * square, MAX_RADIUS)
    points, ok, residual = refine_points(image, coarse, radius, smooth_sigma)
    return _judge(points, ok, residual * scale, square, grid, board)



def _judge(points, ok, residual, square, grid, board) -> Junctions:
    """Fit the grid homography to the refined points and decide what to trust."""
    if ok.sum() < max(4, board.n // 2):
        raise BoardNotFoundError(
            f"only {int(ok.sum())} of {board.n} junctions could be refined to a saddle"
        )
    # On a clean board every junction's fit residual is within ~15 % of the median;
    # a partly covered or smudged junction fits worse.
    ok = ok & (residual <= _RESIDUAL_RATIO * np.median(residual[ok]))
    trusted = ok.copy()
    limit = np.maximum(_GRID_TOLERANCE * square, 1.5)
    for _ in range(3):
        H = fit_homography(grid[:, trusted], points[:, trusted])
        agree = ok & (np.hypot(*(apply_homography(H, grid) - points)) < limit)
        if agree.sum() < max(4, board.n // 2):
            raise BoardNotFoundError(
                f"only {int(agree.sum())} of {board.n} refined junctions agree with a planar grid"
            )
        if np.array_equal(agree, trusted):
            break
        trusted = agree
    else:
        H = fit_homography(grid[:, trusted], points[:, trusted])
    # Where the fit failed, the grid's prediction is the best estimate left; it stays untrusted.
    best = np.where(ok, points, apply_homography(H, grid))
    return Junctions(best, trusted, np.where(ok, residual, np.nan), square, H)

