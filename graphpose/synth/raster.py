"""Rasterisation for :mod:`graphpose.synth.render`: exact polygon areas on a cell grid, and the
blur-and-pixel kernel applied to them.

1. Exact area (:func:`coverage`, :func:`polygon_coverage`): the fraction of every cell of a
   grid covered by polygons, in closed form by Green's theorem over their edges. Regular
   point supersampling would bias edges that run nearly along the grid by up to ~0.1 px;
   exact areas have no such bias. The sparse form (:func:`coverage_entries`,
   :func:`segment_entries`) keeps one entry per edge piece and cell crossed, plus one per
   piece to be summed up its column (:func:`sum_upwards`).
2. The kernel (:func:`pixel_kernel`): a piecewise constant fine image (``S x S`` cells per
   pixel) convolved with a Gaussian and integrated over each pixel in one step,
   ``k = box(1 px) * Gaussian(sigma) * box(1/S px)``; :func:`x_pass` applies it along u to
   sparse entries directly, so that only the columns' sums reach a dense array.

Cell ``(i, j)`` of a grid spans ``[i, i + 1] x [j, j + 1]`` and is array entry ``[j, i]``;
polygons and segments are given in cell units.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

from .._checks import as_polygon, check_size


def polygon_coverage(polygons, size) -> np.ndarray:
    """Exact fraction of every pixel covered by polygons.

    Parameters
    ----------
    polygons : (2, m) array_like or sequence of them
        Simple polygons in pixel coordinates (either orientation). Pixel ``(u, v)``
        covers ``[u - 0.5, u + 0.5] x [v - 0.5, v + 0.5]``. Several polygons must not
        overlap (their coverages add).
    size : (int, int)
        Image ``(width, height)``.

    Returns
    -------
    coverage : (H, W) ndarray of float64
        Covered area of each pixel, px^2 (0..1); parts outside the image are dropped.

    Raises
    ------
    InputError
        If a polygon is not a finite (2, m) array with m >= 3, or size is invalid.
    """

    width, height = check_size(size)
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2:
        polygons = [polygons]
    polys = [as_polygon(P, "polygon") + 0.5 for P in polygons]
    return coverage(polys, height, width)


def coverage(polys, h: int, w: int, weights=None) -> np.ndarray:
    """Covered area of each unit cell ``[i, i+1] x [j, j+1]`` (array entry [j, i]), (h, w), of
    polygons (2, m) in cell units.

    With ``weights`` (one per polygon) the result is the weighted sum of the coverages.
    """
    (full_row, full_col, full_w), (row, col, part_w) = coverage_entries(polys, h, w, weights)
    area = np.bincount(full_row * w + full_col, full_w, h * w).reshape(h, w)
    sum_upwards(area)
    area += np.bincount(row * w + col, part_w, h * w).reshape(h, w)
    return area


def coverage_entries(polys, h: int, w: int, weights=None):
    """Sparse form of :func:`coverage`: ``(full, partial)`` triplets ``(row, col, value)``.

    The coverage is ``sum_upwards(full) + partial``, where ``sum_upwards`` adds each
    entry into every cell of its column at or above its row.

    Green's theorem with ``F = 1[i <= x <= i+1] clamp(y - j, 0, 1)`` (so dF/dy is the
    cell's indicator) gives ``area(P ∩ cell) = -∮_P F dx`` for a positively oriented P.
    Each edge is cut at integer x; on a piece of width ``dx`` the integrand's mean is the
    mean of ``clamp`` of a linear function, in closed form (the partial entries). Cells the
    piece passes entirely below (``y >= j + 1``) get the full ``dx``: one full entry per
    piece, spread upwards later; cells it passes above get nothing. Cells outside the grid
    are dropped, which clips the polygons to it exactly.
    """
    edges, gains = [], []
    for P, gain in zip(polys, np.ones(len(polys)) if weights is None else weights):
        x, y = P
        if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:  # make it positive
            x, y = x[::-1], y[::-1]
        edges.append(np.stack([x, y, np.roll(x, -1), np.roll(y, -1)]))
        gains.append(np.full(x.size, float(gain)))
    return segment_entries(np.concatenate(edges, axis=1), np.concatenate(gains), h, w)


def segment_entries(segments, gains, h: int, w: int):
    """:func:`coverage_entries` of oriented segments ``(x0, y0, x1, y1)`` (4, n) with a gain
    each, which together form positively oriented closed outlines (in any order)."""
    x0, y0, x1, y1 = segments
    keep = x0 != x1
    x0, y0, x1, y1 = x0[keep], y0[keep], x1[keep], y1[keep]
    slope = (y1 - y0) / (x1 - x0)
    sign = np.sign(x1 - x0) * gains[keep]
    xl, xr = np.minimum(x0, x1), np.maximum(x0, x1)
    c_lo = np.maximum(np.floor(xl), 0).astype(np.int64)
    c_hi = np.minimum(np.ceil(xr) - 1, w - 1).astype(np.int64)
    count = np.maximum(c_hi - c_lo + 1, 0)
    edge = np.repeat(np.arange(x0.size), count)
    col = c_lo[edge] + np.arange(edge.size) - np.repeat(np.cumsum(count) - count, count)
    xa = np.maximum(xl[edge], col)
    xb = np.minimum(xr[edge], col + 1)
    ya = y0[edge] + (xa - x0[edge]) * slope[edge]
    yb = y0[edge] + (xb - x0[edge]) * slope[edge]
    weight = -sign[edge] * (xb - xa)
    lo, hi = np.minimum(ya, yb), np.maximum(ya, yb)
    k0 = np.floor(lo).astype(np.int64)
    k1 = np.ceil(hi).astype(np.int64) - 1

    # Full entries: rows j < k0, recorded at row min(k0 - 1, h - 1).
    full_row = np.minimum(k0 - 1, h - 1)
    ok = full_row >= 0
    full = full_row[ok], col[ok], weight[ok]

    # Partial entries: rows k0..k1 that the piece crosses, the mean of clamp(y - k, 0, 1).
    r_lo = np.maximum(k0, 0)
    r_hi = np.minimum(k1, h - 1)
    n_rows = np.maximum(r_hi - r_lo + 1, 0)
    piece = np.repeat(np.arange(col.size), n_rows)
    row = r_lo[piece] + np.arange(piece.size) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows)
    mean = _mean_clamp(lo[piece] - row, hi[piece] - row)
    return full, (row, col[piece], weight[piece] * mean)


def sum_upwards(a: np.ndarray) -> None:
    """In place, ``a[j] = sum(a[j:])`` along axis 0.

    A row loop: numpy's cumsum along axis 0 is several times slower on large arrays.
    """
    for j in range(a.shape[0] - 2, -1, -1):
        np.add(a[j], a[j + 1], out=a[j])


def _mean_clamp(t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Mean of ``clamp(t, 0, 1)`` over ``t`` in ``[t0, t1]`` (``t0 <= t1``), stable as t1 -> t0."""
    span = t1 - t0
    a, b = np.clip(t0, 0.0, 1.0), np.clip(t1, 0.0, 1.0)
    above = np.maximum(t1, 1.0) - np.maximum(t0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = ((b - a) * (a + b) / 2 + above) / span
    return np.where(span > 0, mean, a)


def pixel_kernel(sigma: float, S: int, reach: int) -> np.ndarray:
    """Weights ``k[a, b]`` of fine cell ``(p + a) * S + b`` in pixel p, ``a = -reach..reach``.

    ``k = ∫_{x in [0, 1]} ∫_{y in [d/S, (d+1)/S]} G(x - y) dy dx`` with ``d = a * S + b``:
    the Gaussian blur and the pixel's integration of a piecewise constant fine image.
    """
    d = np.arange(-reach * S, (reach + 1) * S).reshape(2 * reach + 1, S)
    c, e = d / S, (d + 1) / S
    if sigma == 0:
        return np.clip(np.minimum(e, 1.0) - np.maximum(c, 0.0), 0.0, None)

    def H(z):  # antiderivative of Phi(z / sigma)
        return z * ndtr(z / sigma) + sigma * np.exp(-0.5 * (z / sigma) ** 2) / np.sqrt(2 * np.pi)

    return (H(1 - c) - H(-c)) - (H(1 - e) - H(-e))


def x_pass(row, col, values, k, S: int, h: int, w: int) -> list:
    """Blur and integrate along u a sparse fine image given as entries, giving (h, w) arrays.

    Entry ``(row, col, value)`` sits in fine column ``col = p * S + b``; pixel column
    ``p - a`` receives ``value * k[a + reach, b]`` for ``a = -reach..reach``. ``values`` is
    a list of value arrays sharing the positions; one output per value array.
    """
    reach = (k.shape[0] - 1) // 2
    p, b = np.divmod(col, S)
    wide = w + 2 * reach  # room for the kernel's reach beyond either side, cut off below
    index = (row * wide + p + 2 * reach)[:, None] - np.arange(2 * reach + 1)
    kernel = k.T[b]
    # astype: with no entries at all, np.bincount returns int64 even with float weights.
    sums = (np.bincount(index.ravel(), (kernel * v[:, None]).ravel(), h * wide).astype(float, copy=False)
            for v in values)
    return [a.reshape(h, wide)[:, reach : reach + w] for a in sums]
