"""Cross-junctions of the checkerboard, to sub-pixel accuracy, in row-major order.

Two stages.

Coarse localisation
    The bounding polygon's homography resamples the board into a small canonical image
    (about 12 px per square, whatever the perspective). There a saddle response, the
    negative determinant of the Hessian at a scale of a fifth of a square, is high at
    cross-junctions, about four times lower at the L-corners of the outer squares and near
    zero along edges. Its local maxima are the candidates. A lattice is grown from the
    candidate nearest the polygon's centre (predict the four neighbours of every found
    node through a homography fitted to the nodes so far, take the nearest candidate within
    0.3 squares), which ignores clutter that is off the lattice. Of the lattice's
    ``cols x rows`` windows the one whose nodes look most like cross-junctions (a ChESS-like
    ring test that L-corners fail) is the board; it must be nearly complete and fit a
    homography closely, or :class:`~graphpose.errors.BoardNotFoundError` is raised.
Refinement
    Every junction is refined by the saddle fit of :mod:`graphpose.saddle` on a Gaussian-
    smoothed patch, whose window is a smooth disc of radius a fraction of the local square
    (so no other edge enters it), re-centred on the estimate until it stops moving. Around
    the true junction of a blurred checkerboard such a window is point-symmetric, which
    makes the fitted saddle unbiased whatever the perspective. The fit is weighted by the
    squared gradient over the squared distance from the centre, which concentrates it on
    the two edges (where the position information is) and brings its noise within a factor
    ~1.7 of the Cramer-Rao bound; the settings come from measurements on the real and
    synthetic images (see the README section on cross-junctions).

Coordinates follow :mod:`graphpose.camera`: ``(u, v)`` pixels, 0-based, 2 x N arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from .board import Board
from .camera import as_float_array, as_points
from .errors import BoardNotFoundError, InputError
from .homography import homography_dlt
from .io import as_grey
from .saddle import fit_quadrics as _fit

#: Canonical image: pixels per square if the polygon hugged the outer squares' corners.
_CANON_SQUARE = 12.0
#: Hessian scale of the saddle response, canonical pixels.
_CANON_SIGMA = 2.4
#: Default refinement window radius, as a fraction of the local square side.
WINDOW_FRACTION = 0.5
#: Gaussian pre-smoothing of refinement patches, pixels.
SMOOTH_SIGMA = 0.5
#: Largest refinement window radius, pixels (beyond it the fit gains little and costs time).
MAX_RADIUS = 12.0
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
        :func:`graphpose.io.as_grey`); NaN where the fit failed.
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


# ---------------------------------------------------------------------------- public API


def cross_junctions(I, bpoly, Wpts) -> np.ndarray:
    """Cross-junctions of a checkerboard image, row-major from the upper left.

    Parameters
    ----------
    I : (H, W) or (H, W, 3|4) array_like
        The image; colour and 16-bit images are converted by :func:`graphpose.io.as_grey`.
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


def extract_junctions(I, bpoly, board: Board = Board(), *, window: float = WINDOW_FRACTION,
                      smooth_sigma: float = SMOOTH_SIGMA) -> Junctions:
    """Find and refine all cross-junctions of a checkerboard inside a bounding polygon.

    Parameters
    ----------
    I : (H, W) or (H, W, 3|4) array_like
        The image (uint8, uint16, bool or float; colour converted to grey).
    bpoly : (2, 4) array_like
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
        NaN; if ``bpoly`` is not a finite 2 x 4 array, is degenerate, not convex, counter-clockwise, or lies off the
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
    image, scale = _grey(I)
    if min(image.shape) < _MIN_SIDE:
        raise InputError(f"image must be at least {_MIN_SIDE} x {_MIN_SIDE} pixels, got shape {image.shape}")
    poly = _check_polygon(bpoly, image.shape)
    if not 0 < window <= 0.7:
        raise InputError(f"window must be a fraction of the square in (0, 0.7], got {window!r}")
    if not np.isfinite(smooth_sigma) or smooth_sigma < 0:
        raise InputError(f"smooth_sigma must be >= 0 pixels, got {smooth_sigma!r}")
    H_grid = _locate_grid(image, poly, board)
    grid = board.grid_indices().astype(float)
    coarse = _apply(H_grid, grid)
    square = _square_sides(H_grid, grid)
    radius = np.minimum(window * square, MAX_RADIUS)
    points, ok, residual = _refine(image, coarse, radius, smooth_sigma)
    return _judge(points, ok, residual * scale, square, grid, board)


def refine_junctions(I, points, half_width, *, smooth_sigma: float = SMOOTH_SIGMA):
    """Refine predicted junction positions with the re-centred saddle fit.

    The same refinement :func:`extract_junctions` applies after finding the grid; the tracker
    uses it on positions predicted from the previous frame.

    Parameters
    ----------
    I : (H, W) or (H, W, 3|4) array_like
        The image (converted as by :func:`graphpose.io.as_grey`).
    points : (2, m) array_like
        Predicted positions (u, v), pixels; each should be within about a third of the
        window radius of its junction.
    half_width : float or (m,) array_like
        Window radius per point, pixels, >= 2: about half the local square side, so that no
        other edge of the board enters the window.
    smooth_sigma : float
        Gaussian smoothing of the patches, pixels (>= 0).

    Returns
    -------
    points : (2, m) ndarray of float64
        Refined positions; where the fit failed, its last good estimate (or the input).
    trusted : (m,) ndarray of bool
        True where the fit converged to a saddle inside its window, the window lies in the
        image, and a ring around the point looks like a cross-junction (point-symmetric,
        four alternating sectors).
    residual : (m,) ndarray of float64
        RMS residual of the weighted saddle fit, grey units of the image scaled to [0, 1];
        NaN where it failed.

    Raises
    ------
    InputError
        If the image or points are malformed, or ``half_width`` is not >= 2 (scalar or one
        per point).
    """
    image, scale = _grey(I)
    P = as_points(points, 2, "points")
    radius = as_float_array(half_width, "half_width")
    if radius.ndim > 1 or radius.size not in (1, P.shape[1]) or not np.all(np.isfinite(radius)) \
            or np.any(radius < 2):
        raise InputError(f"half_width must be >= 2 px, a scalar or one per point ({P.shape[1]}), "
                         f"got {radius!r}")
    radius = np.broadcast_to(radius, P.shape[1:]).astype(float)
    if not np.isfinite(smooth_sigma) or smooth_sigma < 0:
        raise InputError(f"smooth_sigma must be >= 0 pixels, got {smooth_sigma!r}")
    points, trusted, residual = _refine(image, P, radius, smooth_sigma)
    return points, trusted, residual * scale


# ------------------------------------------------------------------------------ checks


def _grey(I):
    """Grey pixels and the factor that scales them to [0, 1], as :func:`graphpose.io.as_grey`.

    An 8-bit grey image is used as it is (every step but the residual is invariant to the
    grey scale), which spares converting the whole image for the few pixels read.
    """
    if isinstance(I, np.ndarray) and I.dtype == np.uint8 and I.ndim == 2 and I.size:
        return I, 1.0 / 255.0
    return as_grey(I), 1.0


def _check_polygon(bpoly, shape) -> np.ndarray:
    poly = as_float_array(bpoly, "bpoly")
    if poly.shape != (2, 4):
        raise InputError(f"bpoly must have shape (2, 4) (u and v of 4 vertices), got {poly.shape}")
    if not np.all(np.isfinite(poly)):
        raise InputError("bpoly contains NaN or infinite values")
    height, width = shape
    slack = 0.05 * np.hypot(height, width)
    outside = (poly[0] < -slack) | (poly[0] > width - 1 + slack) | \
        (poly[1] < -slack) | (poly[1] > height - 1 + slack)
    if np.any(outside):
        raise InputError(
            f"bpoly vertices {np.flatnonzero(outside).tolist()} lie off the {width} x {height} image "
            f"(more than {slack:.0f} px outside): {poly.round(1).tolist()}"
        )
    edges = np.roll(poly, -1, axis=1) - poly
    turns = edges[0] * np.roll(edges[1], -1) - edges[1] * np.roll(edges[0], -1)
    area = 0.5 * np.sum(poly[0] * np.roll(poly[1], -1) - np.roll(poly[0], -1) * poly[1])
    if abs(area) < 100.0:
        raise InputError(f"bpoly is degenerate (area {abs(area):.1f} px^2): {poly.round(1).tolist()}")
    if area < 0:
        raise InputError("bpoly must run clockwise (in the image, v down) from the upper-left vertex")
    if np.any(turns <= 0):
        raise InputError(f"bpoly must be a convex quadrilateral, got {poly.round(1).tolist()}")
    return poly


# ------------------------------------------------------------------ coarse localisation


def _locate_grid(image: np.ndarray, poly: np.ndarray, board: Board) -> np.ndarray:
    """Homography grid (c, r) -> image (u, v) of the board's junctions."""
    cols, rows = board.cols, board.rows
    width, height = (cols + 2) * _CANON_SQUARE, (rows + 2) * _CANON_SQUARE
    corners = np.array([[0.0, width, width, 0.0], [0.0, 0.0, height, height]])
    H_img = _homography(corners, poly)
    canon = _rectify(image, H_img, int(width) + 1, int(height) + 1)
    response = _saddle_response(canon)
    cand, strength = _peaks(response)
    if cand.shape[1] < board.n // 2:
        raise BoardNotFoundError(
            f"found {cand.shape[1]} junction-like points inside the polygon, need a "
            f"{cols} x {rows} grid; is the board inside bpoly?"
        )
    # A seed that is clutter grows a lattice that fails the checks: try the next ones.
    error = BoardNotFoundError("no strong junction candidate inside the polygon")
    for seed in _seeds(cand, strength, (width / 2, height / 2))[:3]:
        nodes = _grow_lattice(cand, seed, np.array([cols + 3, rows + 3]))
        try:
            return H_img @ _choose_window(nodes, cand, canon, board)
        except BoardNotFoundError as exc:
            error = exc
    raise error


def _rectify(image, H_img, width: int, height: int) -> np.ndarray:
    """The polygon resampled (bilinear) to a canonical ``height x width`` image.

    No anti-aliasing: the saddle response smooths over a fifth of a square anyway, and the
    refinement, not this image, decides the final positions.
    """
    y, x = np.mgrid[0:height, 0:width]
    uv = _apply(H_img, np.vstack([x.ravel(), y.ravel()]).astype(float))
    return _bilinear(image, uv).reshape(height, width)


def _bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear samples of the image at (2, N) points, clamped to its border."""
    h, w = image.shape
    u = np.clip(uv[0], 0.0, w - 1.000001)
    v = np.clip(uv[1], 0.0, h - 1.000001)
    u0 = u.astype(np.intp)
    v0 = v.astype(np.intp)
    fu, fv = u - u0, v - v0
    flat = image.ravel()
    k = v0 * w + u0
    top = flat[k] * (1 - fu) + flat[k + 1] * fu
    bottom = flat[k + w] * (1 - fu) + flat[k + w + 1] * fu
    return top * (1 - fv) + bottom * fv


def _saddle_response(canon: np.ndarray) -> np.ndarray:
    """Negative Hessian determinant: positive at saddles, ~0 on edges, < 0 at blobs.

    One Gaussian smoothing, then central second differences (zero on the border).
    """
    S = ndimage.gaussian_filter(canon, _CANON_SIGMA, truncate=3.0)
    out = np.zeros_like(S)
    Ixx = S[1:-1, 2:] - 2 * S[1:-1, 1:-1] + S[1:-1, :-2]
    Iyy = S[2:, 1:-1] - 2 * S[1:-1, 1:-1] + S[:-2, 1:-1]
    Ixy = 0.25 * (S[2:, 2:] - S[2:, :-2] - S[:-2, 2:] + S[:-2, :-2])
    out[1:-1, 1:-1] = Ixy * Ixy - Ixx * Iyy
    return out


def _peaks(response: np.ndarray):
    """Local maxima of the response: points (2, N) canonical (x, y) and strengths (N,)."""
    local = ndimage.maximum_filter(response, size=5, mode="constant", cval=np.inf)
    ys, xs = np.nonzero((response >= local) & (response > 0))
    values = response[ys, xs]
    if values.size == 0:
        return np.zeros((2, 0)), values
    # Relative to a typical strong peak rather than the strongest, which may be clutter.
    top = np.sort(values)[::-1]
    typical = top[min(len(top) - 1, 10)]
    keep = values > 0.05 * typical
    pts = np.vstack([xs[keep], ys[keep]]).astype(float)
    return _subpixel_peaks(response, pts), values[keep]


def _subpixel_peaks(response, pts):
    """Parabolic sub-pixel interpolation of peak positions (both axes)."""
    x, y = pts.astype(int)
    h, w = response.shape
    xm, xp = np.clip(x - 1, 0, w - 1), np.clip(x + 1, 0, w - 1)
    ym, yp = np.clip(y - 1, 0, h - 1), np.clip(y + 1, 0, h - 1)
    c = response[y, x]
    dx = response[y, xp] - response[y, xm]
    dxx = response[y, xp] - 2 * c + response[y, xm]
    dy = response[yp, x] - response[ym, x]
    dyy = response[yp, x] - 2 * c + response[ym, x]
    with np.errstate(divide="ignore", invalid="ignore"):
        ox = np.where(dxx < 0, -0.5 * dx / dxx, 0.0)
        oy = np.where(dyy < 0, -0.5 * dy / dyy, 0.0)
    return pts + np.vstack([np.clip(ox, -0.5, 0.5), np.clip(oy, -0.5, 0.5)])


def _seeds(cand: np.ndarray, strength: np.ndarray, centre) -> np.ndarray:
    """Indices of strong candidates, nearest the canonical centre first."""
    strong = strength >= 0.25 * np.median(np.sort(strength)[::-1][: max(4, len(strength) // 3)])
    dist = np.hypot(cand[0] - centre[0], cand[1] - centre[1])
    order = np.argsort(dist)
    return order[strong[order]]


def _grow_lattice(cand: np.ndarray, seed: int, max_extent) -> dict:
    """Integer lattice coordinates {(i, j): candidate index} grown from a seed candidate.

    Each round predicts every node of the found nodes' bounding box grown by one (two once
    there are nine nodes), through a homography fitted to the nodes so far (an affine guess
    from the typical steps at first), and takes the nearest unused candidate within 0.3
    squares of each. The box never exceeds ``max_extent`` (i, j) nodes.
    """
    tree = cKDTree(cand.T)
    step = _lattice_steps(cand, tree)
    nodes = {(0, 0): int(seed)}
    tol = 0.3 * min(step[0, 0], step[1, 1])
    for _ in range(max(max_extent) + 2):
        keys = np.array(list(nodes.keys()))
        grow = 1 if len(nodes) < 9 else 2
        lo = np.maximum(keys.min(axis=0) - grow, keys.max(axis=0) - max_extent + 1)
        hi = np.minimum(keys.max(axis=0) + grow, keys.min(axis=0) + max_extent - 1)
        jj, ii = np.mgrid[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1]
        todo = [(i, j) for i, j in zip(ii.ravel().tolist(), jj.ravel().tolist()) if (i, j) not in nodes]
        if not todo:
            break
        pred = _apply(_lattice_model(nodes, cand, step), np.array(todo, dtype=float).T)
        dist, idx = tree.query(pred.T, distance_upper_bound=tol)
        used = set(nodes.values())
        added = 0
        for key, d, k in zip(todo, dist, idx.tolist()):
            if d < tol and k not in used:
                nodes[key] = k
                used.add(k)
                added += 1
        if not added:
            break
    return nodes


def _lattice_steps(cand: np.ndarray, tree: cKDTree) -> np.ndarray:
    """Typical lattice step vectors along canonical x and y, rows of (2, 2)."""
    _, idx = tree.query(cand.T, k=min(5, cand.shape[1]))
    vec = (cand.T[idx[:, 1:]] - cand.T[:, None, :]).reshape(-1, 2)
    horizontal = vec[np.abs(vec[:, 0]) > 2 * np.abs(vec[:, 1])]
    vertical = vec[np.abs(vec[:, 1]) > 2 * np.abs(vec[:, 0])]
    sx = np.median(np.abs(horizontal[:, 0])) if len(horizontal) else _CANON_SQUARE
    sy = np.median(np.abs(vertical[:, 1])) if len(vertical) else _CANON_SQUARE
    return np.array([[sx, 0.0], [0.0, sy]])


def _lattice_model(nodes: dict, cand: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Homography lattice (i, j) -> canonical (x, y) from the nodes found so far."""
    keys = np.array(list(nodes.keys()), dtype=float).T
    pts = cand[:, list(nodes.values())]
    if len(np.unique(keys[0])) >= 3 and len(np.unique(keys[1])) >= 3:
        return _homography(keys, pts)
    origin = cand[:, nodes[(0, 0)]]
    return np.array([[step[0, 0], step[1, 0], origin[0]], [step[0, 1], step[1, 1], origin[1]], [0, 0, 1.0]])


def _choose_window(nodes: dict, cand: np.ndarray, canon: np.ndarray, board: Board) -> np.ndarray:
    """Homography grid (c, r) -> canonical of the cols x rows window of cross-junctions."""
    cols, rows = board.cols, board.rows
    keys = np.array(list(nodes.keys()))
    pts = cand[:, list(nodes.values())]
    i0, j0 = keys.min(axis=0)
    i1, j1 = keys.max(axis=0)
    if i1 - i0 + 1 < cols or j1 - j0 + 1 < rows:
        raise BoardNotFoundError(
            f"found a {i1 - i0 + 1} x {j1 - j0 + 1} grid of junctions inside the polygon, "
            f"need {cols} x {rows}; does bpoly enclose the whole board, first edge along a row?"
        )
    spacing = np.median(_square_sides(_homography(keys.T.astype(float), pts), keys.T.astype(float)))
    score = np.maximum(_chess_score(canon, pts, 0.3 * spacing), 0.0)
    best, best_score = None, -1.0
    for a in range(i0, i1 - cols + 2):
        for b in range(j0, j1 - rows + 2):
            inside = (keys[:, 0] >= a) & (keys[:, 0] < a + cols) & \
                (keys[:, 1] >= b) & (keys[:, 1] < b + rows)
            if score[inside].sum() > best_score:
                best, best_score = (a, b, inside), score[inside].sum()
    a, b, inside = best
    grid = (keys[inside] - [a, b]).T.astype(float)
    found = int(inside.sum())
    crosses = int(np.sum(score[inside] > 0))
    if found < 0.8 * board.n or crosses < 0.8 * board.n:
        raise BoardNotFoundError(
            f"only {found} of {board.n} grid junctions found ({crosses} look like cross-junctions)"
        )
    H = _homography(grid, pts[:, inside])
    err = np.hypot(*(_apply(H, grid) - pts[:, inside]))
    if np.sqrt(np.mean(err**2)) > 0.15 * spacing:
        raise BoardNotFoundError(
            f"the junction candidates do not form a planar grid (RMS {np.sqrt(np.mean(err**2)):.1f} "
            f"canonical px off a homography, square {spacing:.1f})"
        )
    return H


def _chess_score(canon: np.ndarray, pts: np.ndarray, radius: float) -> np.ndarray:
    """ChESS-like ring test: > 0 at cross-junctions, <= 0 at L-corners and edges.

    Opposite ring samples agree at a cross-junction (point symmetry) and quarter-turns
    disagree; an L-corner breaks the first, an edge the second.
    """
    angles = np.arange(16) * (np.pi / 8)
    x = pts[0][:, None] + radius * np.cos(angles)
    y = pts[1][:, None] + radius * np.sin(angles)
    ring = ndimage.map_coordinates(canon, [y.ravel(), x.ravel()], order=1, mode="nearest").reshape(x.shape)
    return _ring_sum(ring) - _ring_diff(ring)


# ------------------------------------------------------------------------- refinement


def _refine(image: np.ndarray, points: np.ndarray, radius: np.ndarray, sigma: float,
            max_iter: int = 8, tol: float = 0.02):
    """Re-centred, gradient-weighted saddle fits: (points (2, m), trusted (m,), residual (m,)).

    Each round refits only the junctions still moving; a junction that drifts off its
    patch's centre gets a new patch.
    """
    m = points.shape[1]
    current = points.astype(float).copy()
    slack = 2
    half = int(np.ceil(radius.max())) + slack
    offs = np.arange(-half, half + 1, dtype=float)
    base = np.rint(current).astype(int)
    patches, grad2, inside = _patches(image, base, half, sigma, radius)
    residual = np.full(m, np.nan)
    state = np.zeros(m, dtype=int)  # 0 moving, 1 converged, 2 failed
    for _ in range(max_iter):
        act = np.flatnonzero(state == 0)
        if act.size == 0:
            break
        drift = act[np.any(np.abs(current[:, act] - base[:, act]) > slack - 0.5, axis=0)]
        if drift.size:
            base[:, drift] = np.rint(current[:, drift])
            fresh = _patches(image, base[:, drift], half, sigma, radius[drift])
            patches[drift], grad2[drift], inside[drift] = fresh
        weights = _weights(offs, current[:, act] - base[:, act], radius[act], grad2[act])
        pts, saddle, within, _, residual[act] = _fit(patches[act], weights)
        new = base[:, act] + pts - half
        step = np.hypot(*(new - current[:, act]))
        ok = saddle & within & (step < radius[act])
        current[:, act[ok]] = new[:, ok]
        state[act[~ok]] = 2
        state[act[ok & (step < tol)]] = 1
    fitted = state != 2
    residual[~fitted] = np.nan
    crosses = _looks_like_cross(patches, current - base + half, 0.6 * radius)
    return current, (state == 1) & inside & crosses, residual


def _patches(image, base, half, sigma, radius):
    """Smoothed patches (m, 2h+1, 2h+1), squared gradients and an in-image mask (m,)."""
    height, width = image.shape
    kernel = _gaussian_kernel(sigma)
    margin = len(kernel) // 2 + 1
    offs = np.arange(-half - margin, half + margin + 1)
    rows = np.clip(base[1][:, None] + offs, 0, height - 1)
    cols = np.clip(base[0][:, None] + offs, 0, width - 1)
    inside = (base[0] - radius >= 0) & (base[0] + radius <= width - 1) & \
        (base[1] - radius >= 0) & (base[1] + radius <= height - 1)
    # Single precision for the pixel work (half the memory traffic); the fit itself, in
    # saddle.fit_quadrics, accumulates in double.
    raw = image.ravel()[(rows * width)[:, :, None] + cols[:, None, :]].astype(np.float32, copy=False)
    smooth = _convolve(_convolve(raw, kernel.astype(np.float32), 1), kernel.astype(np.float32), 2)
    gx = 0.5 * (smooth[:, 1:-1, 2:] - smooth[:, 1:-1, :-2])
    gy = 0.5 * (smooth[:, 2:, 1:-1] - smooth[:, :-2, 1:-1])
    return smooth[:, 1:-1, 1:-1].astype(float), gx * gx + gy * gy, inside


def _gaussian_kernel(sigma: float) -> np.ndarray:
    """Normalised Gaussian taps out to 4 sigma (a single 1 for sigma = 0)."""
    if sigma == 0:
        return np.ones(1)
    t = int(np.ceil(4.0 * sigma))
    k = np.exp(-0.5 * (np.arange(-t, t + 1) / sigma) ** 2)
    return k / k.sum()


def _convolve(a: np.ndarray, kernel: np.ndarray, axis: int) -> np.ndarray:
    """'Valid' correlation with a short symmetric kernel along one axis (shrinks it)."""
    n = a.shape[axis] - len(kernel) + 1
    index = [slice(None)] * a.ndim
    out = 0.0
    for j, k in enumerate(kernel):
        index[axis] = slice(j, j + n)
        out = out + k * a[tuple(index)]
    return out


def _weights(offs, local, radius, grad2):
    """Fit weights (m, h, w) centred on each sub-pixel estimate.

    The squared gradient picks out the two edges, where the position information is; the
    division by the squared distance from the centre favours the inner stretch of each edge,
    which fits the real images better than the outer stretch (measurements in the README's
    cross-junctions section); a smooth taper keeps the window point-symmetric about the
    estimate on the pixel grid.
    """
    inv_r2 = (1.0 / (radius * radius)).astype(np.float32)
    dx2 = ((offs[None, :] - local[0][:, None]) ** 2).astype(np.float32)
    dy2 = ((offs[None, :] - local[1][:, None]) ** 2).astype(np.float32)
    r2 = dy2[:, :, None] + dx2[:, None, :]
    taper = np.maximum(1.0 - r2 * inv_r2[:, None, None], 0.0)
    taper *= taper
    return (taper * grad2 / np.maximum(r2, np.float32(1.0))).astype(float)


def _looks_like_cross(patches, centre, radius):
    """Ring test on the smoothed patches: point-symmetric, with four alternating sectors.

    The ChESS "sum" response (opposite samples against the quarter-turned pair) must be
    at least twice its "diff" response (opposite samples against each other), which noise,
    edges and L-corners fail.
    """
    m = patches.shape[0]
    angles = np.arange(16) * (np.pi / 8)
    x = centre[0][:, None] + radius[:, None] * np.cos(angles)
    y = centre[1][:, None] + radius[:, None] * np.sin(angles)
    k = np.repeat(np.arange(m), 16)
    ring = ndimage.map_coordinates(patches, [k, y.ravel(), x.ravel()], order=1, mode="nearest").reshape(m, 16)
    return _ring_sum(ring) > 2.0 * _ring_diff(ring)


def _ring_sum(ring):
    return np.abs(ring[:, 0:4] + ring[:, 8:12] - ring[:, 4:8] - ring[:, 12:16]).sum(axis=1)


def _ring_diff(ring):
    return np.abs(ring[:, 0:8] - ring[:, 8:16]).sum(axis=1)


# --------------------------------------------------------------------------- verdict


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
        H = _homography(grid[:, trusted], points[:, trusted])
        agree = ok & (np.hypot(*(_apply(H, grid) - points)) < limit)
        if agree.sum() < max(4, board.n // 2):
            raise BoardNotFoundError(
                f"only {int(agree.sum())} of {board.n} refined junctions agree with a planar grid"
            )
        if np.array_equal(agree, trusted):
            break
        trusted = agree
    else:
        H = _homography(grid[:, trusted], points[:, trusted])
    # Where the fit failed, the grid's prediction is the best estimate left; it stays untrusted.
    best = np.where(ok, points, _apply(H, grid))
    return Junctions(best, trusted, np.where(ok, residual, np.nan), square, H)


def _square_sides(H: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Smaller height of the parallelogram spanned by the local grid steps, pixels."""
    du = _apply(H, grid + [[0.5], [0.0]]) - _apply(H, grid - [[0.5], [0.0]])
    dv = _apply(H, grid + [[0.0], [0.5]]) - _apply(H, grid - [[0.0], [0.5]])
    area = np.abs(du[0] * dv[1] - du[1] * dv[0])
    return area / np.maximum(np.hypot(*du), np.hypot(*dv))


# ------------------------------------------------------------------------ homographies


def _homography(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Homography mapping src (2, N) to dst (2, N), scaled so ``H[2, 2] = 1``.

    Junctions that do not fix one (collinear, coincident) mean no board was found.
    """
    try:
        H = homography_dlt(src, dst)
    except InputError as exc:
        raise BoardNotFoundError(f"the junctions found do not fix a homography: {exc}") from None
    return H / H[2, 2]


def _apply(H: np.ndarray, P: np.ndarray) -> np.ndarray:
    q = H[:, :2] @ P + H[:, 2:]
    return q[:2] / q[2]
