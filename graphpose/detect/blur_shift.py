"""The shift that blur gives a junction whose edges a lens curves, and the image's edge blur.

A lens's distortion bends the board's straight edges in the raw image, and the camera's blur
(its optics, the pixels' area) acts on the raw image: on the curved edges. A blurred edge
curved with curvature ``kappa`` moves towards its centre of curvature, and at a junction the
saddle of two such edges moves along each edge's normal by ``kappa sigma^2``, ``sigma^2`` the
blur's variance (the image's own and the refinement's smoothing, in raw pixels). To first order,
with the two edges' unit normals ``n_i`` towards their centres of curvature and the curvatures
``kappa_i >= 0``, the saddle moves by ``s`` with

    n_1 . s = kappa_1 sigma^2,    n_2 . s = kappa_2 sigma^2

(from the blurred X-junction ``erf(x_1) erf(x_2)`` with the first edge bent to
``x_1 = kappa x_2^2 / 2``: its saddle is at ``x_1 = kappa sigma^2``). The saddle fit through the
lens (:mod:`graphpose.detect.refine`) takes the edges straight in each patch's own frame, as the
lens makes them, but not this shift, which the blur made before the lens could be undone.

On a fisheye (about 190 degrees) with a blur of one pixel the shift is a few thousandths of a
pixel, inwards on average: small against one junction's noise, but the same on every junction,
so a pose takes it whole as a distance (the lens benchmark's fisheye views: pose NEES 8.5
against 6 with it, 5.8 without). :func:`blur_shift` gives it from the lens and the board's grid, and
:func:`edge_blur` measures the image's blur on the board's own edges.

Coordinates follow :mod:`graphpose.geometry`.
"""

from __future__ import annotations

import numpy as np

#: Angle (radians) along each edge's great circle of the central differences that give its
#: curvature in the raw image: a few pixels at the focal lengths of wide lenses.
_STEP_RAD = 1e-2
#: Half the strip across an edge that :func:`edge_blur` reads, pixels, and at most this
#: fraction of the square's side (the strip must not reach the next edge).
_STRIP_PX, _STRIP_FRACTION = 5.0, 0.3
#: Half the length along an edge that :func:`edge_blur` reads, pixels, and at most this
#: fraction of the edge.
_ALONG_PX, _ALONG_FRACTION = 4.0, 0.25
#: Fewest edges that give :func:`edge_blur` an answer, and the most it reads (spread over the
#: board: the blur is the lens's and the focus's, which change slowly across it).
MIN_EDGES, MAX_EDGES = 4, 12
#: The largest ``|kappa| sigma`` (an edge's curvature times the blur's sigma) at which the
#: first-order shift holds: beyond it (near where a strong radial term folds the image back,
#: where the curvature grows without bound) a junction is left as fitted, not moved by a
#: formula that no longer describes it. On a lens that keeps its image one-to-one this is far
#: from reached (``|kappa| sigma`` about 1e-3).
MAX_CURVATURE_BLUR = 0.05


def blur_shift(lens, points, grid, variance, rays=None):
    """The shift (2, n) that a blur of ``variance`` gives each junction through ``lens``.

    Parameters
    ----------
    lens : Camera
        The camera (:mod:`graphpose.camera_models`) of the raw image.
    points : (2, n) ndarray
        The junctions, raw pixels (u, v), in the board's order; NaN where not seen.
    grid : (2, n) ndarray
        Each junction's (column, row) on the board (:meth:`graphpose.Board.grid_indices`).
    variance : float
        The blur's variance in raw pixels^2: the image's (:func:`edge_blur`) and any
        smoothing of it before the saddle fit.
    rays : (3, n) ndarray, optional
        The junctions' unit rays, where the caller has them (NaN where not); by default
        ``lens.unproject(points)``.

    Returns
    -------
    shift : (2, n) ndarray
        Where the blur moves each junction's saddle, pixels: subtract it from a fitted
        junction. Zero where a junction or its ray is unknown, where it has no seen neighbour
        along its row or its column, where its two edges are nearly parallel, or where an
        edge bends too sharply for the first-order shift (``|kappa| sigma`` above
        :data:`MAX_CURVATURE_BLUR`).
    """
    n = points.shape[1]
    shift = np.zeros((2, n))
    if rays is None:
        rays = np.full((3, n), np.nan)
        seen = np.all(np.isfinite(points), axis=0)
        rays[:, seen] = lens.unproject(points[:, seen])
    known = np.all(np.isfinite(rays), axis=0)
    rays = np.where(known, rays, 0.0)
    row, col = (np.where(known, _neighbours(rays, grid, axis, known), -1) for axis in (0, 1))
    idx = np.flatnonzero((row >= 0) & (col >= 0))
    if idx.size == 0:
        return shift
    normals, kappa = _edge_curvature(lens, rays[:, idx], [rays[:, row[idx]], rays[:, col[idx]]])
    s = _saddle_shift(normals[0], normals[1], kappa[0], kappa[1], variance)
    with np.errstate(invalid="ignore"):
        gentle = np.all(np.abs(kappa) * np.sqrt(variance) <= MAX_CURVATURE_BLUR, axis=0)
    good = np.all(np.isfinite(s), axis=0) & gentle
    shift[:, idx[good]] = s[:, good]
    return shift


def _saddle_shift(n1, n2, k1, k2, variance):
    """The saddle's shift (2, m) of two blurred edges with unit normals ``n1``, ``n2`` (2, m)
    and signed curvatures ``k1``, ``k2`` (m,) along them, for a blur of ``variance``:
    ``n_i . s = k_i variance``; NaN where the edges are within ~6 degrees of parallel.

    (Near the saddle the blurred junction is ``c (m1 m2 - rho (m1^2 + m2^2) / 2)``, ``m_i =
    n_i . x``, ``rho = n1 . n2``, ``c = 2 / (pi sigma^2 sqrt(1 - rho^2))``, and bending edge ``i``
    adds the gradient ``-(2 / pi) k_i sign(n_j . t_i) t_i``, ``t_i`` its tangent: where the two
    cancel, ``n_i . s = k_i sigma^2`` at any angle between the edges.)
    """
    det = n1[0] * n2[1] - n1[1] * n2[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = variance * np.vstack([k1 * n2[1] - k2 * n1[1], k2 * n1[0] - k1 * n2[0]]) / det
    return np.where(np.abs(det) > 0.1, s, np.nan)


def _neighbours(points, grid, axis, seen=None):
    """For each junction the index of a seen neighbour along the board's ``axis`` (0: its
    row, 1: its column): the next one, else the previous one, else -1. ``seen`` (n,) says
    which are seen; by default those with finite ``points``."""
    cols, rows = int(grid[0].max()) + 1, int(grid[1].max()) + 1
    table = np.full((rows + 2, cols + 2), -1)  # a border of -1 all round
    seen = np.all(np.isfinite(points), axis=0) if seen is None else seen
    c, r = grid.astype(np.intp)
    table[r[seen] + 1, c[seen] + 1] = np.flatnonzero(seen)
    dc, dr = (1, 0) if axis == 0 else (0, 1)
    after, before = table[r + 1 + dr, c + 1 + dc], table[r + 1 - dr, c + 1 - dc]
    return np.where(after >= 0, after, before)


def _edge_curvature(lens, rays, others):
    """The raw image's unit normals (2 of (2, m)) and signed curvatures (2, m) of the edges at
    the junctions with unit ``rays`` (3, m) towards each array of ``others`` (2 of (3, m)): each
    edge the great circle through the two rays (a straight line's image on the view sphere).
    The normal is the edge's left-hand one; the curvature is positive where the edge bends
    towards it (1 / pixels)."""
    h, m = _STEP_RAD, rays.shape[1]
    steps = []
    for other in others:
        tangent = np.cross(np.cross(rays.T, other.T), rays.T).T
        tangent /= np.linalg.norm(tangent, axis=0)
        steps += [np.cos(h) * rays + np.sin(h) * tangent, np.cos(h) * rays - np.sin(h) * tangent]
    c = lens.project(np.hstack([rays, *steps]))  # one call: the junctions, then each edge's +h, -h
    c0 = c[:, :m]
    normals, kappa = [], []
    for e in range(len(others)):
        cp, cm = c[:, (1 + 2 * e) * m:(2 + 2 * e) * m], c[:, (2 + 2 * e) * m:(3 + 2 * e) * m]
        d1, d2 = (cp - cm) / (2 * h), (cp - 2 * c0 + cm) / h**2
        speed2 = np.sum(d1 * d1, axis=0)
        normal = np.vstack([-d1[1], d1[0]]) / np.sqrt(speed2)
        normals.append(normal)
        kappa.append(np.sum(d2 * normal, axis=0) / speed2)
    return normals, np.array(kappa)


def edge_blur(image, points, grid, square):
    """The blur of the image across the board's edges: the variance, pixels^2, of the edge
    spread function (a Gaussian's, through the pixels' area) that fits the grey values across
    the middle of every edge between two seen neighbours; the median over the edges.

    Parameters
    ----------
    image : (H, W) ndarray
        The grey image, as the refinement reads it (not smoothed).
    points : (2, n) ndarray
        The junctions, pixels (u, v); NaN where not seen.
    grid : (2, n) ndarray
        Each junction's (column, row) on the board.
    square : (n,) ndarray
        The local square side at each junction, pixels.

    Returns
    -------
    variance : float
        Pixels^2; NaN where fewer than :data:`MIN_EDGES` edges could be read.
    """
    i, j = [], []
    seen = np.all(np.isfinite(points), axis=0)
    for axis in (0, 1):  # each edge once: from a seen junction to its next seen neighbour
        after = _neighbours(points, grid, axis)
        forward = np.flatnonzero(seen & (after >= 0) & (grid[axis, np.maximum(after, 0)] > grid[axis]))
        i.append(forward)
        j.append(after[forward])
    i, j = np.concatenate(i), np.concatenate(j)
    if i.size < MIN_EDGES:
        return float("nan")
    # The edges nearest the board's middle (all those tied with the last): the same edges
    # however the board is labelled (a half turn), so the same answer.
    middle = np.hypot(*(0.5 * (grid[:, i] + grid[:, j]) - 0.5 * grid.max(axis=1, keepdims=True)))
    near = middle <= np.sort(middle)[min(MAX_EDGES, middle.size) - 1] + 1e-9
    i, j = i[near], j[near]
    # An edge whose two junctions have no local square side (a partial board's rim) has no
    # strip to read: left out.
    sides = np.vstack([square[i], square[j]])
    known = np.any(np.isfinite(sides), axis=0)
    if np.count_nonzero(known) < MIN_EDGES:
        return float("nan")
    i, j = i[known], j[known]
    p, q = points[:, i], points[:, j]
    side = np.hypot(*(q - p))
    half = np.minimum(_STRIP_PX, _STRIP_FRACTION * np.nanmin(sides[:, known], axis=0))
    # Every edge's strip: the pixels within `half` of the chord across it, `span` along it.
    t = (q - p) / side
    n_ = np.vstack([-t[1], t[0]])
    mid = 0.5 * (p + q)
    span = np.minimum(_ALONG_PX, _ALONG_FRACTION * side)
    reach = int(np.ceil(np.max(np.hypot(span, half)))) + 1
    o = np.arange(-reach, reach + 1)
    du, dv = np.meshgrid(o, o)
    u = np.rint(mid[0])[:, None] + du.ravel()[None, :]
    v = np.rint(mid[1])[:, None] + dv.ravel()[None, :]
    across = (u - mid[0][:, None]) * n_[0][:, None] + (v - mid[1][:, None]) * n_[1][:, None]
    length = (u - mid[0][:, None]) * t[0][:, None] + (v - mid[1][:, None]) * t[1][:, None]
    inside = (u >= 0) & (v >= 0) & (u < image.shape[1]) & (v < image.shape[0])
    use = inside & (np.abs(across) <= half[:, None]) & (np.abs(length) <= span[:, None])
    e, k = np.nonzero(use)
    grey = image[v[e, k].astype(np.intp), u[e, k].astype(np.intp)].astype(float)
    variance = _fit_edges(e, across[e, k], grey, len(i))
    keep = np.isfinite(variance)
    return float(np.median(variance[keep])) if keep.sum() >= MIN_EDGES else float("nan")


def _fit_edges(edge, d, grey, count, iterations=1):
    """Gauss-Newton fits of ``a + b Phi((d - d0) / s)`` to the grey values ``grey`` (k,) at
    signed distances ``d`` (k,) from their edges ``edge`` (k,) (indices below ``count``); each
    edge's ``s^2`` (count,), NaN where its fit fails or the blur fills most of its strip."""
    # Imported here: only a raw image through a lens reads its blur, and SciPy's import costs
    # ``graphpose estimate`` on a pinhole image most of its start (tests/test_startup.py).
    from scipy.special import ndtr, ndtri

    def total(x):
        return np.bincount(edge, weights=x, minlength=count)

    n = np.maximum(total(np.ones_like(d)), 1.0)
    reach = total(np.abs(d)) / n  # the strip's mean half-width: about half of it
    # The start: the plateaus from the strip's outer halves, then the profile's probit, which
    # is (d - d0) / s for a Gaussian's edge, fitted as a line where it is well inside (0, 1).
    outer = np.abs(d) > reach[edge]
    lo = total(grey * outer * (d < 0)) / np.maximum(total(outer * (d < 0) * 1.0), 1.0)
    hi = total(grey * outer * (d > 0)) / np.maximum(total(outer * (d > 0) * 1.0), 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = (grey - lo[edge]) / (hi - lo)[edge]
        w = ((y > 0.1) & (y < 0.9)) * 1.0
        z = ndtri(np.clip(y, 0.1, 0.9))
        sw, sd, sz, sdd, sdz = (total(w * q) for q in (np.ones_like(d), d, z, d * d, d * z))
        slope = (sw * sdz - sd * sz) / (sw * sdd - sd * sd)
        x = np.stack([lo, hi - lo, (sd - sz / slope) / sw, np.clip(1.0 / slope, 0.05, 10.0)], axis=1)
    x[~np.isfinite(x[:, 2]), 2] = 0.0
    x[~np.isfinite(x[:, 3]), 3] = 1.0
    cells = 20 * edge[:, None] + np.arange(20)  # each sample's sums: J^T J (16), J^T r (4)
    for _ in range(iterations):
        b, s = x[edge, 1], x[edge, 3]
        z = (d - x[edge, 2]) / s
        cdf = ndtr(z)
        slope = -b * np.exp(-0.5 * z * z) / (np.sqrt(2 * np.pi) * s)
        J = np.stack([np.ones_like(z), cdf, slope, slope * z], axis=1)  # (k, 4): a, b, d0, s
        r = grey - (x[edge, 0] + b * cdf)
        sums = np.bincount(cells.ravel(), weights=np.hstack([(J[:, :, None] * J[:, None, :]).reshape(-1, 16),
                                                              J * r[:, None]]).ravel(), minlength=20 * count)
        JtJ, Jtr = sums.reshape(count, 20)[:, :16].reshape(count, 4, 4), sums.reshape(count, 20)[:, 16:]
        x = x + np.linalg.solve(JtJ + 1e-12 * np.eye(4), Jtr[..., None])[..., 0]
        x[:, 3] = np.clip(np.abs(x[:, 3]), 0.05, 10.0)
    ok = (np.abs(x[:, 2]) < reach) & (x[:, 3] < reach) & np.all(np.isfinite(x), axis=1) & (n >= 12)
    return np.where(ok, x[:, 3] ** 2, np.nan)
