"""Cross-junctions of the checkerboard, to sub-pixel accuracy, in row-major order.

Two stages a caller can stop between, as scikit-image's ``corner_harris`` ->
``corner_peaks`` -> ``corner_subpix``: :func:`find_board` finds and labels the board
anywhere in the image, or inside optional bounds (:mod:`.find`: candidates, lattices, and
labels from the board's edges; no camera needed), as a :class:`FoundBoard`; :func:`refine`
fits a saddle at every junction seen (:mod:`.refine`, through the lens when a camera is
given) and decides which junctions to trust, as :class:`Junctions`.
:func:`extract_junctions` is the two in a row. Junctions the image does not show (off the
image, covered) are NaN and untrusted: never guessed.

Coordinates follow :mod:`graphpose.geometry`: ``(u, v)`` pixels, 0-based, 2 x N arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._checks import check_bounds, check_number
from ..board import Board, check_board
from ..errors import BoardNotFoundError, InputError
from ..geometry import apply_homography
from ..observations import MIN_JUNCTIONS
from .find import FoundBoard
from .find import find_board as _search
from .blur_shift import blur_shift, edge_blur
from .noise import bounding_window, estimate_noise, grey_range
from .grid import fit_homography, square_sides
from .search import median
from .refine import (
    MAX_RADIUS,
    SMOOTH_SIGMA,
    WINDOW_FRACTION,
    grey_and_scale,
    noise_smoothing,
    refine_points,
)

#: Smallest image side, pixels: the smallest refinement window (radius 2) must fit, and the
#: bilinear resampling needs two rows and columns.
MIN_SIDE = 5

#: A junction whose refined position is farther than this from the grid homography's
#: prediction (fraction of the local square) is not trusted ...
_GRID_TOLERANCE = 0.08
#: ... nor one farther than five times the board's own spread about it, kept within these
#: bounds (pixels): a trusted junction is never a pixel off the grid its board draws.
_GATE_PX = (0.3, 1.0)

#: A junction whose fit residual exceeds this multiple of the board's median is not trusted
#: (the six real images stay within 0.85-1.14 of their medians).
_RESIDUAL_RATIO = 1.5


@dataclass(frozen=True)
class Junctions:
    """Cross-junctions found in one image.

    Attributes
    ----------
    points : (2, n) ndarray of float64
        Junction positions (u, v), pixels, row-major from junction 0 (see
        ``orientation_ambiguous``); NaN for junctions the image does not show.
    trusted : (n,) ndarray of bool
        True where the saddle fit converged to a saddle inside its window, the window lies
        inside the image, a ring around the point looks like a cross-junction, its fit
        residual is at most 1.5 times the board's median, and the point agrees with the
        homography fitted to the other trusted junctions (within five times the board's own
        spread, 0.3 to 1 px, and 8 % of the square).
        Untrusted points that were seen are still the best estimate available (refined, or
        predicted by the grid where refinement failed); a pose should use the trusted ones.
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
    seen : (n,) ndarray of bool
        Junctions the image shows (on the board's lattice); the others are NaN.
    orientation_ambiguous : bool
        True when the board's pattern is unchanged by a half (or quarter) turn and no
        bounds said which corner is junction 0: the labels then follow the rule that
        junction 0 is the corner junction nearest the image's upper-left corner
        (``docs/conventions.md``), and the pose is one of two (or four) that fit equally.
    junction0_square : str or None
        ``"dark"`` or ``"light"``: the colour of junction 0's outer corner square (the
        board's corner square diagonally beyond junction 0 from its neighbours), measured in
        the image. Dark unless bounds named junction 0 at a corner whose square is light
        (``docs/conventions.md``), so two images that name different physical corners say
        so. None when the junctions were not extracted from an image.
    """

    points: np.ndarray
    trusted: np.ndarray
    residual: np.ndarray
    square_px: np.ndarray
    homography: np.ndarray
    seen: np.ndarray
    orientation_ambiguous: bool = False
    junction0_square: str | None = None


def extract_junctions(image, *, board: Board = Board(), bounds=None, camera=None, window: float = WINDOW_FRACTION,
                      smooth_sigma: float | None = None) -> Junctions:
    """Find, label and refine the cross-junctions of a checkerboard.

    :func:`find_board`, then :func:`refine`, with every argument checked before the search.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image (uint8, uint16, bool or float; colour converted to grey).
    board : Board
        The board spec: ``cols x rows`` inner junctions.
    bounds : (2, 4) array_like, optional
        The board's outline, pixels, clockwise from the corner nearest junction 0: it
        narrows the search and fixes which corner is junction 0. A loose outline (a few
        pixels inside the margin or outside the sheet) gives the same result. Without it
        the whole image is searched.
    camera : Camera or (3, 3) array_like, optional
        The camera (:mod:`graphpose.camera_models`) when the image is raw, with lens distortion.
        Junctions are found and refined on the raw image as it is (both steps are local);
        only the check that they lie on a planar grid is made on undistorted positions,
        and :attr:`Junctions.homography` then maps the grid to undistorted pixels.
    window : float
        Refinement window radius as a fraction of the local square side, in (0, 0.7].
    smooth_sigma : float, optional
        Gaussian smoothing of refinement patches, pixels (>= 0). By default it follows the
        image's noise over the board's contrast (:func:`graphpose.detect.refine.noise_smoothing`):
        :data:`graphpose.detect.refine.SMOOTH_SIGMA` on clean images, more under noise.

    Returns
    -------
    Junctions
        Points (2, n) row-major (NaN where unseen), trust mask, fit residuals, local
        square sizes, the grid-to-image homography, the seen mask and the orientation flag.

    Raises
    ------
    InputError
        If the image is empty, smaller than 5 x 5 pixels, not 2-D grey or colour, or holds
        NaN; if ``bounds`` is not a finite 2 x 4 array, is degenerate, not convex,
        counter-clockwise, or lies off the image; if ``window`` or ``smooth_sigma`` is out of
        range.
    BoardNotFoundError
        With the reason: no board; a board of another size than the spec; two boards and
        no bounds; a partial board whose labels its visible edges cannot fix; fewer than
        six junctions refined and trusted.

    Examples
    --------
    >>> from graphpose import bundled_cases, read_image, extract_junctions
    >>> case = bundled_cases().cases[0]
    >>> J = extract_junctions(read_image(case.image))
    >>> J.points.shape, bool(J.trusted.all()), J.orientation_ambiguous
    ((2, 48), True, True)
    """
    image, scale = grey_and_scale(image, MIN_SIDE)
    poly = None if bounds is None else check_bounds(bounds, image.shape)
    # refine's arguments are checked before the search, so that a bad one costs no search.
    window, smooth_sigma = _check_refinement(window, smooth_sigma)
    lens = _lens(camera, image.shape)
    noise = estimate_noise(image) if smooth_sigma is None else None
    return _refine(image, scale, _find(image, board, poly, noise), lens, window, smooth_sigma)


def find_board(image, board: Board, *, bounds=None) -> FoundBoard:
    """Find the board in an image and label its junctions: the first stage of
    :func:`extract_junctions`, with no camera.

    The labels (each junction's board index, row-major from junction 0) come from the
    board's edges in the image, so a raw image through a lens is searched as it is. The
    result is what :func:`refine` makes sub-pixel, once or through several cameras (a
    calibration searches each image once and refines it at every pass).

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image (uint8, uint16, bool or float; colour converted to grey as by
        :func:`graphpose.image.as_grey`; 8-bit grey is used as it is), at least 5 x 5 pixels.
    board : Board
        The board spec: ``cols x rows`` inner junctions.
    bounds : (2, 4) array_like, optional
        The board's outline, pixels, clockwise from the corner nearest junction 0 (as
        :func:`extract_junctions` takes it): it narrows the search and fixes which corner
        is junction 0. Without it the whole image is searched.

    Returns
    -------
    FoundBoard
        Coarse positions (2, n) row-major (NaN where unseen), the seen mask, the local
        lattice steps, the orientation flag, the board and the image's measured noise.

    Raises
    ------
    InputError
        If the image, ``board`` or ``bounds`` is malformed (as :func:`extract_junctions`).
    BoardNotFoundError
        With the reason: no board; a board of another size than the spec
        (:class:`graphpose.errors.BoardMismatchError`); two boards and no bounds; a partial
        board whose labels its visible edges cannot fix.

    Examples
    --------
    >>> from graphpose import Board, bundled_cases, read_image
    >>> from graphpose.detect import find_board
    >>> found = find_board(read_image(bundled_cases().cases[0].image), Board())
    >>> found.points.shape, found.labels.size, found.orientation_ambiguous
    ((2, 48), 48, True)
    """
    grey, _ = grey_and_scale(image, MIN_SIDE)
    board = check_board(board)
    poly = None if bounds is None else check_bounds(bounds, grey.shape)
    return _find(grey, board, poly, estimate_noise(grey))


def refine(image, found: FoundBoard, *, camera=None, window: float = WINDOW_FRACTION,
           smooth_sigma: float | None = None) -> Junctions:
    """Refine a found board's junctions to sub-pixel and judge which to trust: the second
    stage of :func:`extract_junctions`.

    Every seen junction is refined by the re-centred saddle fit (:mod:`graphpose.detect.refine`),
    in a window of ``window`` times its local square; the verdict then keeps the junctions
    whose fits converged, look like cross-junctions, fit about as well as the board's
    others, and lie on the board's planar grid (:class:`Junctions`).

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image ``found`` was found in (converted as :func:`find_board` converts it).
    found : FoundBoard
        What :func:`find_board` found in ``image``.
    camera : Camera or (3, 3) array_like, optional
        The camera (:mod:`graphpose.camera_models`) when the image is raw, with lens
        distortion: each junction is then fitted where the lens straightens the board's
        edges and has the shift the blur gives it on edges the lens curves taken off
        (:mod:`graphpose.detect.blur_shift`, the blur measured on the board's edges), the
        planar-grid check is made on undistorted positions, and
        :attr:`Junctions.homography` maps the grid to undistorted pixels. A camera without
        distortion (or none) refines on the image as it is. Its size, if known, must be the
        image's.
    window : float
        Refinement window radius as a fraction of the local square side, in (0, 0.7].
    smooth_sigma : float, optional
        Gaussian smoothing of refinement patches, pixels (>= 0). By default it follows the
        image's noise (``found.noise``) over the board's contrast (:func:`board_smoothing`).

    Returns
    -------
    Junctions
        As :func:`extract_junctions` returns them: ``refine(image, find_board(image, board,
        bounds=bounds), camera=camera)`` equals ``extract_junctions(image, bounds, board,
        camera=camera)`` exactly.

    Raises
    ------
    InputError
        If the image is malformed, ``found`` is not a :class:`FoundBoard` of a board with
        the image's junctions, ``camera`` is not a camera or K, its size is not the image's,
        or ``window`` or ``smooth_sigma`` is out of range.
    BoardNotFoundError
        If fewer than six junctions (or half of those seen) are refined and trusted, or too
        few lie on a planar grid (the message says a lens's distortion may be why).

    Examples
    --------
    >>> from graphpose import Board, bundled_cases, read_image
    >>> from graphpose.detect import find_board, refine
    >>> image = read_image(bundled_cases().cases[0].image)
    >>> J = refine(image, find_board(image, Board()))
    >>> J.points.shape, bool(J.trusted.all())
    ((2, 48), True)
    """
    grey, scale = grey_and_scale(image, MIN_SIDE)
    _check_found(found, grey.shape)
    window, smooth_sigma = _check_refinement(window, smooth_sigma)
    return _refine(grey, scale, found, _lens(camera, grey.shape), window, smooth_sigma)


def _check_found(found, shape) -> None:
    """Refuse a ``found`` that is not a :class:`FoundBoard` of its board's junctions."""
    if not isinstance(found, FoundBoard):
        raise InputError(f"found must be a FoundBoard (what find_board returns), got {type(found).__name__}")
    if not isinstance(found.board, Board):
        raise InputError("found must name its board (found.board, as find_board sets it), got None")
    n = found.board.n
    if np.shape(found.points) != (2, n) or np.shape(found.seen) != (n,) or np.shape(found.step_px) != (n,):
        raise InputError(f"found must hold the {n} junctions of its {found.board.cols} x {found.board.rows} board: "
                         f"points (2, {n}), seen and step_px ({n},); got points {np.shape(found.points)}")


def _check_refinement(window, smooth_sigma):
    """``window`` and ``smooth_sigma`` checked, as :func:`refine` takes them."""
    window = check_number("window (a fraction of the square)", window, 0.0, strict=True, maximum=0.7)
    if smooth_sigma is not None:
        smooth_sigma = check_number("smooth_sigma", smooth_sigma, 0.0)
    return window, smooth_sigma


def _lens(camera, shape):
    """The camera to refine through: ``camera`` (checked against the image ``shape``) when it
    distorts, else None."""
    if camera is None:
        return None
    from ..camera_models import as_camera, check_image_size

    lens = as_camera(camera)
    check_image_size(lens, shape)
    return None if not np.any(lens.distortion) else lens


def _find(image, board, poly, noise) -> FoundBoard:
    """:func:`find_board`'s search on the grey ``image`` with checked bounds ``poly``, the
    image's ``noise`` (None: measured only if the noise-aware search runs) kept in the result."""
    return replace(_search(image, board, poly, noise=noise), noise=noise)


def _refine(image, scale, found, lens, window, smooth_sigma) -> Junctions:
    """:func:`refine` on checked arguments: the grey ``image`` and its grey unit ``scale`` (the
    residuals' scale), the distorting ``lens`` or None (:func:`_lens`)."""
    board, noise = found.board, found.noise
    seen = found.seen
    grid = board.grid_indices().astype(float)
    square = np.full(board.n, np.nan)
    square[seen] = square_sides(fit_homography(grid[:, seen], found.points[:, seen]), grid[:, seen])
    radius = np.minimum(window * square[seen], MAX_RADIUS)
    if smooth_sigma is None:
        smooth_sigma = board_smoothing(image, found.points[:, seen], square[seen], noise)
    points = np.full((2, board.n), np.nan)
    ok = np.zeros(board.n, dtype=bool)
    residual = np.full(board.n, np.nan)
    flat = None if lens is None else np.full((2, int(seen.sum())), np.nan)
    points[:, seen], ok[seen], residual[seen] = refine_points(image, found.points[:, seen], radius, smooth_sigma,
                                                              lens=lens, undistorted=flat)
    if lens is not None:
        _unblur(image, points, flat, seen, grid, square, lens, smooth_sigma)
    J = _judge(points, ok, residual * scale, square, grid, seen, found.orientation_ambiguous, lens, flat)
    return replace(J, junction0_square=found.junction0_square)


def _unblur(image, points, flat, seen, grid, square, lens, smooth_sigma) -> None:
    """Take from the junctions fitted through a distorting ``lens`` the shift the blur gave
    them (:mod:`.blur_shift`: the raw image's blur, measured on the board's edges, and the
    refinement's smoothing, acting on edges the lens curves), in place in ``points`` (2, n).
    Left as fitted where the image's blur cannot be read (too few edges). Their
    distortion-free pixels ``flat`` (2, seen), which the trust gate's homography is fitted to,
    stay as the fits gave them: the shift is a few thousandths of a pixel, the gate 0.3 px."""
    variance = edge_blur(image, points, grid, square)
    if not np.isfinite(variance):
        return
    rays = np.full((3, points.shape[1]), np.nan)  # the fits' own rays, NaN where none
    fitted = np.all(np.isfinite(flat), axis=0)
    if fitted.any():
        rays[:, np.flatnonzero(seen)[fitted]] = lens.pinhole().unproject(flat[:, fitted])
    points -= blur_shift(lens, points, grid, variance + smooth_sigma**2, rays=rays)


def board_smoothing(image: np.ndarray, points: np.ndarray, square: np.ndarray, noise: float | None = None) -> float:
    """The refinement's Gaussian smoothing for a board in an image, pixels.

    :func:`graphpose.detect.refine.noise_smoothing` of the image's ``noise`` over the grey
    range of the board's bounding box (5th to 95th percentile: its black and white squares):
    :data:`graphpose.detect.refine.SMOOTH_SIGMA` on clean images, more under noise. What
    :func:`refine` uses by default; a tracker that refines predicted junctions
    (:func:`graphpose.detect.refine_junctions`) sets its smoothing from it at each detection.

    Parameters
    ----------
    image : (H, W) ndarray
        Grey image (8-bit as it is, else as :func:`graphpose.image.as_grey` makes it).
    points : (2, m) ndarray
        The board's junctions seen, pixels (u, v).
    square : (m,) ndarray
        Their local square sides, pixels (NaN ignored).
    noise : float, optional
        The image's pixel noise, grey units (:func:`graphpose.detect.estimate_noise`);
        measured when None.

    Returns
    -------
    float
        Smoothing sigma, pixels.
    """
    crop = bounding_window(image, points)
    if min(crop.shape) < 3:
        return SMOOTH_SIGMA
    contrast = grey_range(crop, stride=2, tail=5.0)
    noise = estimate_noise(image) if noise is None else noise
    return noise_smoothing(noise, contrast, median(square[~np.isnan(square)]))


def _deleted_offsets(H, grid, flat, fitted) -> np.ndarray:
    """Distance (px) of each point from the grid homography fitted without it.

    ``H`` is fitted to the ``fitted`` columns of ``grid`` (2, n) and ``flat`` (2, n). A point
    outside the fit is judged by its plain residual; a point inside it by its deleted residual,
    ``(I - A_i)^-1 e_i``, with ``A_i`` its 2 x 2 block of the fit's hat matrix (the fit
    linearised in H's eight free entries, ``H[2, 2] = 1``): to first order, its distance from
    the homography fitted to the others. NaN where ``flat`` is NaN; inf for a point the
    others do not fix at all.
    """
    n = grid.shape[1]
    x = np.vstack([grid, np.ones(n)])
    w = H[2] @ x
    p = (H[:2] @ x) / w
    e = flat - p
    A = np.zeros((n, 2, 8))
    A[:, 0, 0:3] = (x / w).T
    A[:, 1, 3:6] = (x / w).T
    A[:, 0, 6:8] = -(p[0] * x[:2] / w).T
    A[:, 1, 6:8] = -(p[1] * x[:2] / w).T
    Af = A[fitted].reshape(-1, 8)
    scale = np.linalg.norm(Af, axis=0)
    Q = np.linalg.qr(Af / scale)[0].reshape(-1, 2, 8)  # the hat blocks of the fitted points: Q_i Q_i^T
    hat = np.einsum("nik,njk->nij", Q, Q)
    D = np.eye(2) - hat
    det = D[:, 0, 0] * D[:, 1, 1] - D[:, 0, 1] * D[:, 1, 0]
    ef = e[:, fitted].T
    with np.errstate(divide="ignore", invalid="ignore"):
        du = (D[:, 1, 1] * ef[:, 0] - D[:, 0, 1] * ef[:, 1]) / det
        dv = (D[:, 0, 0] * ef[:, 1] - D[:, 1, 0] * ef[:, 0]) / det
    off = np.hypot(*e)
    off[fitted] = np.where(det > 1e-12, np.hypot(du, dv), np.inf)
    return off


def _judge(points, ok, residual, square, grid, seen, ambiguous, lens=None, undistorted=None) -> Junctions:
    """Fit the grid homography to the refined points and decide what to trust.

    With a distorting ``lens`` the homography is fitted to, and judged on, the undistorted
    positions (a planar grid is a homography only through a pinhole): ``undistorted`` (2, seen),
    as the refinement gave them (:func:`graphpose.detect.refine.refine_points`).
    """
    flat = points.copy()
    if lens is not None:  # unseen junctions stay NaN
        # Only the junctions the refinement trusts are judged; each has its ray from its fit.
        flat[:, seen] = np.where(ok[seen], undistorted, np.nan)
    ok = ok & np.all(np.isfinite(flat), axis=0)
    n_seen = int(seen.sum())
    need = max(MIN_JUNCTIONS, n_seen // 2)
    if ok.sum() < need:
        raise BoardNotFoundError(
            f"only {int(ok.sum())} of the {n_seen} junctions seen could be refined to a saddle "
            f"(need {need})")
    # On a clean board every junction's fit residual is within ~15 % of the median;
    # a partly covered or smudged junction fits worse.
    ok = ok & (residual <= _RESIDUAL_RATIO * median(residual[ok]))
    trusted = ok.copy()
    for _ in range(4):
        H = fit_homography(grid[:, trusted], flat[:, trusted])
        off = _deleted_offsets(H, grid, flat, trusted)
        # The board's own spread sets the gate: five of its sigmas (the median distance of
        # a 2-D normal is 1.18 sigma), between 0.3 px and 1 px, and never a fraction of a
        # small square more. A junction a sticker or a bar half covers is pulled further.
        # Each junction is judged against the grid the *other* junctions draw: on a small
        # part of a board a junction pulls the homography towards itself, and its plain
        # residual hides much of its error.
        sigma = median(off[trusted]) / 1.18
        limit = np.minimum(np.clip(5.0 * sigma, _GATE_PX[0], _GATE_PX[1]), np.maximum(_GRID_TOLERANCE * square, _GATE_PX[0]))
        with np.errstate(invalid="ignore"):
            agree = ok & (off < limit)
        if agree.sum() < need:
            hint = "" if lens is not None else (
                "; a raw image through a lens with distortion does not: give the camera's calibration "
                "(a camera model, e.g. read_camera(FILE); on the command line --camera FILE; to make "
                "one, graphpose calibrate)")
            raise BoardNotFoundError(
                f"only {int(agree.sum())} of the {n_seen} junctions seen agree with a planar grid "
                f"(need {need}){hint}")
        if np.array_equal(agree, trusted):
            break
        trusted = agree
    else:
        H = fit_homography(grid[:, trusted], flat[:, trusted])
    # Where the fit failed on a junction that was seen, the grid's prediction is the best
    # estimate left; it stays untrusted. Unseen junctions stay NaN.
    best = np.where(ok, points, np.nan)
    lost = seen & ~ok
    if lost.any():
        predicted = apply_homography(H, grid[:, lost])
        best[:, lost] = predicted if lens is None else lens.distort_pixels(predicted)
    return Junctions(best, trusted, np.where(ok, residual, np.nan), np.where(seen, square, np.nan), H,
                     seen.copy(), bool(ambiguous))
