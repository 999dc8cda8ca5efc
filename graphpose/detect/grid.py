"""Coarse localisation of the junction grid.

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

Coordinates follow :mod:`graphpose.camera`.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..board import Board
from ..errors import BoardNotFoundError, InputError
from ..pose.homography import homography_dlt
from .refine import ring_diff, ring_sum

#: Canonical image: pixels per square if the polygon hugged the outer squares' corners.
_CANON_SQUARE = 12.0

#: Hessian scale of the saddle response, canonical pixels.
_CANON_SIGMA = 2.4



def locate_grid(image: np.ndarray, poly: np.ndarray, board: Board) -> np.ndarray:
    """Homography grid (c, r) -> image (u, v) of the board's junctions."""
    cols, rows = board.cols, board.rows
    width, height = (cols + 2) * _CANON_SQUARE, (rows + 2) * _CANON_SQUARE
    corners = np.array([[0.0, width, width, 0.0], [0.0, 0.0, height, height]])
    H_img = fit_homography(corners, poly)
    canon = _rectify(image, H_img, int(width) + 1, int(height) + 1)
    response = _saddle_response(canon)
    cand, strength = _peaks(response)
    if cand.shape[1] < board.n // 2:
        raise BoardNotFoundError(
            f"found {cand.shape[1]} junction-like points inside the polygon, need a "
            f"{cols} x {rows} grid; is the board inside the bounds?"
        )
    # A seed that is clutter grows a lattice that fails the checks: try the next ones, and
    # if all fail, report the one that came nearest to a board.
    failures = [(-1, "no strong junction candidate inside the polygon")]
    for seed in _seeds(cand, strength, (width / 2, height / 2))[:3]:
        nodes = _grow_lattice(cand, seed, np.array([cols + 3, rows + 3]))
        try:
            H, failure = _choose_window(nodes, cand, canon, board)
        except BoardNotFoundError as exc:  # the lattice fixes no homography
            H, failure = None, (0, str(exc))
        if H is not None:
            return H_img @ H
        failures.append(failure)
    raise BoardNotFoundError(max(failures, key=lambda f: f[0])[1])



def _rectify(image, H_img, width: int, height: int) -> np.ndarray:
    """The polygon resampled (bilinear) to a canonical ``height x width`` image.

    No anti-aliasing: the saddle response smooths over a fifth of a square anyway, and the
    refinement, not this image, decides the final positions.
    """
    y, x = np.mgrid[0:height, 0:width]
    uv = apply_homography(H_img, np.vstack([x.ravel(), y.ravel()]).astype(float))
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
        pred = apply_homography(_lattice_model(nodes, cand, step), np.array(todo, dtype=float).T)
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
        return fit_homography(keys, pts)
    origin = cand[:, nodes[(0, 0)]]
    return np.array([[step[0, 0], step[1, 0], origin[0]], [step[0, 1], step[1, 1], origin[1]], [0, 0, 1.0]])



def _choose_window(nodes: dict, cand: np.ndarray, canon: np.ndarray, board: Board):
    """Homography grid (c, r) -> canonical of the cols x rows window of cross-junctions.

    Returns ``(H, None)``, or ``(None, (rank, message))`` saying why the lattice holds no
    board; the rank (0-3) grows with how far the lattice got, so that of several seeds'
    lattices the nearest miss is reported.
    """
    cols, rows = board.cols, board.rows
    keys = np.array(list(nodes.keys()))
    pts = cand[:, list(nodes.values())]
    i0, j0 = keys.min(axis=0)
    i1, j1 = keys.max(axis=0)
    if i1 - i0 + 1 < cols or j1 - j0 + 1 < rows:
        # The lattice holds the cross-junctions and the L-corners around them, so a whole
        # board spans two more than its junctions each way.
        return None, (0, (
            f"the junctions found inside the polygon span {i1 - i0 + 1} x {j1 - j0 + 1}, which holds "
            f"no {cols} x {rows} grid: does the polygon hold the whole board, its first edge along "
            f"a row of {cols} junctions?"))
    spacing = np.median(square_sides(fit_homography(keys.T.astype(float), pts), keys.T.astype(float)))
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
    if found < 0.8 * board.n:
        return None, (1, (
            f"only {found} of the {cols} x {rows} = {board.n} junctions were found inside the polygon "
            f"({crosses} of them look like cross-junctions): does the polygon hold the whole board?"))
    if crosses < 0.8 * board.n:
        # A complete window whose nodes are largely L-corners: the squares' outer corners
        # fill the places of junctions the board does not have.
        return None, (2, (
            f"only {crosses} of the {cols} x {rows} junctions inside the polygon look like "
            f"cross-junctions, the others like corners of the outer squares: the board has fewer "
            f"inner junctions than {cols} x {rows} (columns along the polygon's first edge; a board "
            f"counts inner junctions, one fewer than squares each way), or the polygon cuts part "
            f"of it off"))
    H = fit_homography(grid, pts[:, inside])
    err = np.hypot(*(apply_homography(H, grid) - pts[:, inside]))
    if np.sqrt(np.mean(err**2)) > 0.15 * spacing:
        return None, (3, (
            f"the junction candidates do not form a planar grid (RMS {np.sqrt(np.mean(err**2)):.1f} "
            f"canonical px off a homography, square {spacing:.1f})"))
    return H, None



def _chess_score(canon: np.ndarray, pts: np.ndarray, radius: float) -> np.ndarray:
    """ChESS-like ring test: > 0 at cross-junctions, <= 0 at L-corners and edges.

    Opposite ring samples agree at a cross-junction (point symmetry) and quarter-turns
    disagree; an L-corner breaks the first, an edge the second.
    """
    angles = np.arange(16) * (np.pi / 8)
    x = pts[0][:, None] + radius * np.cos(angles)
    y = pts[1][:, None] + radius * np.sin(angles)
    ring = ndimage.map_coordinates(canon, [y.ravel(), x.ravel()], order=1, mode="nearest").reshape(x.shape)
    return ring_sum(ring) - ring_diff(ring)



def square_sides(H: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Smaller height of the parallelogram spanned by the local grid steps, pixels."""
    du = apply_homography(H, grid + [[0.5], [0.0]]) - apply_homography(H, grid - [[0.5], [0.0]])
    dv = apply_homography(H, grid + [[0.0], [0.5]]) - apply_homography(H, grid - [[0.0], [0.5]])
    area = np.abs(du[0] * dv[1] - du[1] * dv[0])
    return area / np.maximum(np.hypot(*du), np.hypot(*dv))



def fit_homography(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Homography mapping src (2, N) to dst (2, N), scaled so ``H[2, 2] = 1``.

    Junctions that do not fix one (collinear, coincident) mean no board was found.
    """
    try:
        H = homography_dlt(src, dst)
    except InputError as exc:
        raise BoardNotFoundError(f"the junctions found do not fix a homography: {exc}") from None
    return H / H[2, 2]



def apply_homography(H: np.ndarray, P: np.ndarray) -> np.ndarray:
    q = H[:, :2] @ P + H[:, 2:]
    return q[:2] / q[2]

